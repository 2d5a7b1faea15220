"""One name per parameter: each job's options struct is bound field by field under the C++ field's name,
the Python keywords are those names, the CLI takes them as flags, and the older Python spellings still
work with a DeprecationWarning."""

import warnings

import numpy as np
import pytest

import microshadow as ms
from microshadow import _microshadow as core
from microshadow import _options
from conftest import ROOT


STRUCTS = ["SamplingOptions", "BakeOptions", "ReprBakeOptions", "SweepOptions", "DfgOptions", "EnvironmentSource",
           "PrefilterOptions", "IrradianceOptions", "AreaOptions", "SceneOptions", "DesignOptions"]


@pytest.mark.parametrize("name", STRUCTS)
def test_every_bound_field_reads_and_writes_back(name):
    options = getattr(core, name)()
    for field in type(options)._fields:
        value = getattr(options, field)
        setattr(options, field, value)  # the C++ default survives the round trip
        assert getattr(options, field) == value or repr(getattr(options, field)) == repr(value), field
    assert repr(options).startswith(name + "(")


def test_a_name_that_is_not_a_field_is_refused():
    # build() sets attributes by name: a keyword whose field was renamed fails here, never silently.
    with pytest.raises(AttributeError):
        _options.build("BakeOptions", size_visibility=4)
    with pytest.raises(AttributeError):
        _options.build("DfgOptions", size_n_dot_v=4)


def test_enumerations_read_and_write_as_the_cli_spells_them():
    s = _options.sampling(method="sampled", tolerance=0, samples=64, replicates=2, seed=1, sequence="random",
                          form="uncorrelated", ao_weighting="uniform", backend="oracle", device="default")
    assert (s.method, s.sequence, s.form, s.ao_weighting, s.backend) == ("sampled", "random", "uncorrelated", "uniform",
                                                                        "oracle")
    with pytest.raises(ValueError, match="method = 'Exact' .*exact, sampled"):
        s.method = "Exact"
    sweep = core.SweepOptions()
    assert sweep.method is None
    sweep.method = "exact"
    sweep.method = None
    assert sweep.method is None


def test_ibl_dfg_takes_the_struct_names_and_the_old_ones_with_a_warning(cli, tmp_path):
    dfg = ms.ibl_dfg(size=4, n_dot_v_count=3, roughness_count=2, method="exact")
    assert dfg.data.shape == (2, 3, 3)
    # The CLI takes the same names as flags (its older --size-n-dot-v, --size-roughness too).
    dfg.save(tmp_path / "dfg.h")
    (tmp_path / "cli").mkdir()
    cli("ibl", "dfg", "--out", tmp_path / "cli" / "dfg.h", "--size", "4", "--n-dot-v-count", "3", "--roughness-count", "2",
        "--method", "exact", "-q")
    # The same texels, as the C header's array (its comment names the command, so not the whole file).
    text = [p.read_text() for p in (tmp_path / "dfg.h", tmp_path / "cli" / "dfg.h")]
    assert [t[t.index("static const float"):] for t in text][0] == [t[t.index("static const float"):] for t in text][1]
    with pytest.warns(DeprecationWarning, match=r"ibl_dfg\(size_n_dot_v=\) is deprecated: use n_dot_v_count="):
        old = ms.ibl_dfg(size=4, size_n_dot_v=3, size_roughness=2, method="exact")
    np.testing.assert_array_equal(old.data, dfg.data)
    with pytest.raises(TypeError, match="both size_roughness= and roughness_count="):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            ms.ibl_dfg(size_roughness=2, roughness_count=2)


def test_bake_keeps_its_deprecated_count_names():
    with pytest.warns(DeprecationWarning, match=r"bake\(size_n_dot_l=\) is deprecated: use n_dot_l_count="):
        old = ms.bake(layout="custom", size=2, size_n_dot_l=3, roughness=[0.5], samples=64, replicates=2, backend="oracle")
    new = ms.bake(layout="custom", size=2, n_dot_l_count=3, roughness=[0.5], samples=64, replicates=2, backend="oracle")
    np.testing.assert_array_equal(old.data, new.data)


def test_public_names_are_kept():
    for name in ["evaluate", "evaluate_iso", "lookup_inputs", "bake", "open", "Lut", "Representation", "repr_bake",
                 "REPR_PRESETS", "analytic", "ANALYTIC_TERMS", "sweep", "SweepTable", "ibl_dfg", "DfgLut",
                 "ibl_prefilter", "PrefilteredEnvironment", "ibl_irradiance", "IrradianceMap", "ibl_sh", "ShIrradiance",
                 "area_eval", "AreaResult", "scene", "SceneRun", "design", "DesignTable", "__version__"]:
        assert name in ms.__all__ and hasattr(ms, name), name
    assert ms.Lut.__module__ == "microshadow"


# --- One name per parameter across the three front ends --------------------------------------------------
# Each command, the Python function that runs it and the public structs its parameters are the fields of:
# bound options structs (their `_fields`) and the query structs of include/microshadow/*.hpp (read from
# the header: a query's fields are Python's per-query arguments and, for area eval, its CSV's columns).
FRONT_ENDS = [
    (["eval"], "evaluate", ["SamplingOptions", "types.hpp:Query"]),
    (["bake"], "bake", ["BakeOptions", "SamplingOptions"]),
    (["repr", "bake"], "repr_bake", ["ReprBakeOptions", "SamplingOptions"]),
    (["sweep"], "sweep", ["SweepOptions"]),
    (["ibl", "dfg"], "ibl_dfg", ["DfgOptions"]),
    (["ibl", "prefilter"], "ibl_prefilter", ["PrefilterOptions", "EnvironmentSource"]),
    (["ibl", "irradiance"], "ibl_irradiance", ["IrradianceOptions", "EnvironmentSource"]),
    (["area", "eval"], "area_eval", ["AreaOptions", "SamplingOptions", "area.hpp:AreaQuery"]),
    (["scene"], "scene", ["SceneOptions"]),
    (["design"], "design", ["DesignOptions"]),
]

# The only names that may differ, each with its reason; a new difference fails the test.
NOT_A_CLI_FLAG = {
    # A nested struct: its own fields are the command's flags (SamplingOptions: --method, --samples, ...;
    # EnvironmentSource: the positional ENV and --faces).
    "sampling", "environment",
    # The environment image is the commands' positional argument ENV (Python: the first positional
    # argument, `environment`, as PrefilterOptions' field holding it is named).
    "image",
    # Per-query values: evaluate's arguments and area eval's CSV columns (wi_x,wi_y,wi_z; light_x,light_y,
    # light_z for light_direction; corner columns), not flags. area eval's --light is the shape, as `light`.
    "visibility", "alpha_x", "alpha_y", "wi", "wo", "light_direction", "half_angle_deg", "corners",
}
NOT_A_PYTHON_KEYWORD = {
    "sampling", "image",  # flattened into their fields; the image is `environment`
    # The area term has no float exact kernel (its exact method runs on the host's threads); the CLI's
    # shared sampling flags accept --exact-float there and ignore it, Python refuses it.
    ("area_eval", "exact_float"),
}
# Python keywords that are no field: the progress callback, the positional input files (CLI positional
# arguments too), and deprecated spellings (each warns and names its replacement; tests above and below).
PYTHON_ONLY = {
    "evaluate": {"progress"},
    "bake": {"progress", "size_visibility", "size_n_dot_l", "size_n_dot_v"},
    "repr_bake": {"progress"},
    "sweep": {"progress", "spec", "toml"},
    "ibl_dfg": {"progress", "size_n_dot_v", "size_roughness"},
    "ibl_prefilter": {"progress", "no_fis"},
    "ibl_irradiance": {"progress"},
    "area_eval": {"progress"},
    "scene": {"progress", "path"},
    "design": {"progress"},
}


def _header_fields(where):
    """The field names of `struct NAME` in include/microshadow/HEADER (where = "HEADER:NAME")."""
    import re
    header, name = where.split(":")
    text = (ROOT / "include" / "microshadow" / header).read_text()
    body = re.search(r"struct " + name + r" \{(.*?)\n\};", text, re.S).group(1)
    fields = []
    for line in body.splitlines():
        line = re.sub(r"//.*", "", line).strip()
        if not line.endswith(";") or "(" in line:
            continue
        line = re.sub(r"<[^<>]*>", "", re.sub(r"\{[^{}]*\}", "", line[:-1]))  # initialisers, template arguments
        declarators = [re.sub(r"=.*", "", d).strip() for d in line.split(",")]
        fields.append(declarators[0].split()[-1])
        fields.extend(declarators[1:])
    return fields


def _fields(struct):
    if ":" in struct:
        return _header_fields(struct), {}
    options = getattr(core, struct)()
    return list(type(options)._fields), {f: getattr(options, f) for f in type(options)._fields}


def _cli_flags(cli, command):
    """The flags `microshadow COMMAND --help` lists (hidden older spellings are not listed)."""
    import re
    return set(re.findall(r"(?<![\w-])--[a-z0-9][a-z0-9-]*", cli(*command, "--help").stdout))


def _cli_spellings(field, default):
    """The flag a field has: --name with '_' -> '-'; a boolean that defaults to true the negative flag
    --no-name (as --no-skip, --no-analytic, --no-fis); a list field (luts) the repeatable singular (--lut)."""
    flag = field.replace("_", "-")
    if default is True:
        return ["--no-" + flag]
    if isinstance(default, list) and field.endswith("s"):
        return ["--" + flag, "--" + flag[:-1]]
    return ["--" + flag]


def test_the_header_reader_finds_every_field():
    assert _header_fields("types.hpp:Query") == ["visibility", "alpha_x", "alpha_y", "wi", "wo"]
    assert _header_fields("area.hpp:AreaQuery")[-1] == "corners"


@pytest.mark.parametrize("command,function,structs", FRONT_ENDS, ids=[f for _, f, _ in FRONT_ENDS])
def test_every_field_is_one_name_in_all_three_front_ends(cli, command, function, structs):
    import inspect
    flags = _cli_flags(cli, command)
    keywords = set(inspect.signature(getattr(ms, function)).parameters)
    names = set()
    for struct in structs:
        fields, defaults = _fields(struct)
        names.update(fields)
        for field in fields:
            if field not in NOT_A_CLI_FLAG:
                spellings = _cli_spellings(field, defaults.get(field))
                assert flags & set(spellings), f"{struct}.{field}: `microshadow {' '.join(command)}` has no {spellings[0]}"
            if field not in NOT_A_PYTHON_KEYWORD and (function, field) not in NOT_A_PYTHON_KEYWORD:
                assert field in keywords, f"{struct}.{field}: {function}() has no keyword {field}="
    extra = keywords - names - PYTHON_ONLY[function]
    assert not extra, f"{function}() keywords that are no field of {structs}: {sorted(extra)}"


def test_the_older_cli_flags_are_hidden_and_still_work(cli, tmp_path):
    help_text = cli("bake", "--help").stdout
    assert "--visibility-count" in help_text and "--size-visibility" not in help_text
    assert "--size-roughness" not in cli("ibl", "dfg", "--help").stdout
    common = ["bake", "--layout", "custom", "--size", "2", "--roughness", "0.5", "--samples", "64", "--replicates", "2",
              "--backend", "oracle", "-q"]
    cli(*common, "--out", tmp_path / "new.exr", "--visibility-count", "3", "--n-dot-l-count", "4", "--n-dot-v-count", "2")
    cli(*common, "--out", tmp_path / "old.exr", "--size-visibility", "3", "--size-n-dot-l", "4", "--size-n-dot-v", "2")
    new, old = ms.open(tmp_path / "new.exr"), ms.open(tmp_path / "old.exr")
    assert new.data.shape == old.data.shape
    np.testing.assert_array_equal(new.data, old.data)
    # The old spelling is checked as the new one is, naming the flag as typed; both at once are refused.
    bad = cli(*common, "--out", tmp_path / "bad.exr", "--size-visibility", "0x4", check=False)
    assert bad.returncode == 2 and "--size-visibility: '0x4' is not a decimal integer" in bad.stderr, bad.stderr
    both = cli(*common, "--out", tmp_path / "both.exr", "--size-visibility", "3", "--visibility-count", "3", check=False)
    assert both.returncode == 2 and "--size-visibility" in both.stderr, both.stderr
