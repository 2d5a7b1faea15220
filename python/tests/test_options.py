"""One name per parameter: each job's options struct is bound field by field under the C++ field's name,
the Python keywords are those names, the CLI takes them as flags, and the older Python spellings still
work with a DeprecationWarning."""

import warnings

import numpy as np
import pytest

import microshadow as ms
from microshadow import _microshadow as core
from microshadow import _options


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
