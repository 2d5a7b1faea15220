// The public API's option structs as Python classes: one attribute per field, named as the field (and
// as the Python keyword and, with dashes, the CLI flag). The package builds each job's struct from its
// keyword arguments in one place (python/microshadow/_options.py) and hands it to the job's binding, so a
// new field is one line here and one keyword there. Enumerations read and write as the CLI spells them.
#include "bindings.hpp"

namespace microshadow_python {
namespace {

template <class E>
using Spellings = std::vector<std::pair<const char*, E>>;

const Spellings<Method>& method_names() {
    static const Spellings<Method> names{{"exact", Method::exact}, {"sampled", Method::sampled}};
    return names;
}
const Spellings<Backend>& backend_names() {
    static const Spellings<Backend> names{{"opencl", Backend::opencl}, {"oracle", Backend::oracle}};
    return names;
}
const Spellings<Sequence>& sequence_names() {
    static const Spellings<Sequence> names{{"sobol", Sequence::sobol}, {"random", Sequence::random}};
    return names;
}
const Spellings<Form>& form_names() {
    static const Spellings<Form> names{{"height-correlated", Form::height_correlated}, {"uncorrelated", Form::uncorrelated}};
    return names;
}
const Spellings<AoWeighting>& ao_weighting_names() {
    static const Spellings<AoWeighting> names{{"cosine", AoWeighting::cosine}, {"uniform", AoWeighting::uniform}};
    return names;
}
const Spellings<Lobe>& lobe_names() {
    static const Spellings<Lobe> names{{"ggx", Lobe::ggx}, {"lambert", Lobe::lambert}};
    return names;
}

template <class E>
E parse(const char* field, const std::string& text, const Spellings<E>& names) {
    std::string allowed;
    for (const auto& [name, value] : names) {
        if (text == name) return value;
        allowed += (allowed.empty() ? "" : ", ") + std::string(name);
    }
    throw std::invalid_argument(std::string(field) + " = '" + text + "' (one of " + allowed + ")");
}
template <class E>
std::string spelled(E value, const Spellings<E>& names) {
    for (const auto& [name, v] : names)
        if (v == value) return name;
    throw std::logic_error("an enumeration value without a name");
}

// A field of enumeration type as a string attribute.
template <class C, class E>
void enum_field(py::class_<C>& cls, const char* field, E C::*member, const Spellings<E>& names) {
    cls.def_property(
        field, [member, &names](const C& c) { return spelled(c.*member, names); },
        [field, member, &names](C& c, const std::string& text) { c.*member = parse(field, text, names); });
}
// A field of type optional<enumeration> as a string attribute that also takes None (unset).
template <class C, class E>
void optional_enum_field(py::class_<C>& cls, const char* field, std::optional<E> C::*member, const Spellings<E>& names) {
    cls.def_property(
        field,
        [member, &names](const C& c) -> std::optional<std::string> {
            if (!(c.*member)) return std::nullopt;
            return spelled(*(c.*member), names);
        },
        [field, member, &names](C& c, const std::optional<std::string>& text) {
            if (text)
                c.*member = parse(field, *text, names);
            else
                c.*member = std::nullopt;
        });
}

// Where a job runs: every struct with a backend and a device binds them here, so that how a backend is
// chosen changes in one place.
template <class C>
void backend_fields(py::class_<C>& cls) {
    enum_field(cls, "backend", &C::backend, backend_names());
    cls.def_readwrite("device", &C::device);
}

// Every field of a struct, as a dict (the repr and the tests that check the binding lists every field).
template <class C>
void describe(py::class_<C>& cls, const char* name) {
    cls.def("__repr__", [name](const py::object& self) {
        py::list parts;
        for (const py::handle key : self.attr("_fields")) {
            parts.append(py::str("{}={!r}").format(key, self.attr(key)));
        }
        return py::str("{}({})").format(name, py::str(", ").attr("join")(parts));
    });
}

}  // namespace

void bind_options(py::module_& m) {
    py::class_<SamplingOptions> sampling(m, "SamplingOptions");
    sampling.def(py::init<>());
    enum_field(sampling, "method", &SamplingOptions::method, method_names());
    backend_fields(sampling);
    sampling.def_readwrite("samples", &SamplingOptions::samples)
        .def_readwrite("replicates", &SamplingOptions::replicates)
        .def_readwrite("seed", &SamplingOptions::seed)
        .def_readwrite("tolerance", &SamplingOptions::tolerance)
        .def_readwrite("fast_math", &SamplingOptions::fast_math)
        .def_readwrite("exact_float", &SamplingOptions::exact_float);
    enum_field(sampling, "ao_weighting", &SamplingOptions::ao_weighting, ao_weighting_names());
    enum_field(sampling, "form", &SamplingOptions::form, form_names());
    enum_field(sampling, "sequence", &SamplingOptions::sequence, sequence_names());
    sampling.attr("_fields") = py::make_tuple("method", "backend", "device", "samples", "replicates", "seed", "ao_weighting",
                                              "form", "tolerance", "sequence", "fast_math", "exact_float");
    describe(sampling, "SamplingOptions");

    py::class_<BakeOptions> bake(m, "BakeOptions");
    bake.def(py::init<>())
        .def_readwrite("layout", &BakeOptions::layout)
        .def_readwrite("size", &BakeOptions::size)
        .def_readwrite("visibility_count", &BakeOptions::visibility_count)
        .def_readwrite("n_dot_l_count", &BakeOptions::n_dot_l_count)
        .def_readwrite("n_dot_v_count", &BakeOptions::n_dot_v_count)
        .def_readwrite("roughness", &BakeOptions::roughness)
        .def_readwrite("tolerance", &BakeOptions::tolerance)
        .def_readwrite("sampling", &BakeOptions::sampling)
        .def_readwrite("texel", &BakeOptions::texel)
        .def_readwrite("azimuth", &BakeOptions::azimuth)
        .def_readwrite("visibility_range", &BakeOptions::visibility_range)
        .def_readwrite("n_dot_l_range", &BakeOptions::n_dot_l_range)
        .def_readwrite("n_dot_v_range", &BakeOptions::n_dot_v_range)
        .def_readwrite("max_batches", &BakeOptions::max_batches);
    bake.attr("_fields") = py::make_tuple("layout", "size", "visibility_count", "n_dot_l_count", "n_dot_v_count", "roughness",
                                          "tolerance", "sampling", "texel", "azimuth", "visibility_range", "n_dot_l_range",
                                          "n_dot_v_range", "max_batches");
    describe(bake, "BakeOptions");

    py::class_<ReprBakeOptions> repr(m, "ReprBakeOptions");
    repr.def(py::init<>())
        .def_readwrite("preset", &ReprBakeOptions::preset)
        .def_readwrite("kind", &ReprBakeOptions::kind)
        .def_readwrite("visibility_count", &ReprBakeOptions::visibility_count)
        .def_readwrite("n_dot_l_count", &ReprBakeOptions::n_dot_l_count)
        .def_readwrite("n_dot_v_count", &ReprBakeOptions::n_dot_v_count)
        .def_readwrite("azimuth_nodes", &ReprBakeOptions::azimuth_nodes)
        .def_readwrite("roughness", &ReprBakeOptions::roughness)
        .def_readwrite("roughness_count", &ReprBakeOptions::roughness_count)
        .def_readwrite("n_dot_v_warp", &ReprBakeOptions::n_dot_v_warp)
        .def_readwrite("n_dot_l_warp", &ReprBakeOptions::n_dot_l_warp)
        .def_readwrite("visibility_warp", &ReprBakeOptions::visibility_warp)
        .def_readwrite("sampling", &ReprBakeOptions::sampling);
    repr.attr("_fields") = py::make_tuple("preset", "kind", "visibility_count", "n_dot_l_count", "n_dot_v_count", "azimuth_nodes",
                                          "roughness", "roughness_count", "n_dot_v_warp", "n_dot_l_warp", "visibility_warp",
                                          "sampling");
    describe(repr, "ReprBakeOptions");

    py::class_<SweepOptions> sweep(m, "SweepOptions");
    sweep.def(py::init<>())
        .def_readwrite("out", &SweepOptions::out)
        .def_readwrite("tolerance", &SweepOptions::tolerance)
        .def_readwrite("samples", &SweepOptions::samples)
        .def_readwrite("replicates", &SweepOptions::replicates)
        .def_readwrite("seed", &SweepOptions::seed)
        .def_readwrite("fast_math", &SweepOptions::fast_math)
        .def_readwrite("exact_float", &SweepOptions::exact_float);
    optional_enum_field(sweep, "method", &SweepOptions::method, method_names());
    optional_enum_field(sweep, "sequence", &SweepOptions::sequence, sequence_names());
    optional_enum_field(sweep, "form", &SweepOptions::form, form_names());
    optional_enum_field(sweep, "ao_weighting", &SweepOptions::ao_weighting, ao_weighting_names());
    backend_fields(sweep);
    sweep.attr("_fields") = py::make_tuple("out", "method", "tolerance", "samples", "replicates", "seed", "sequence", "form",
                                           "ao_weighting", "backend", "device", "fast_math", "exact_float");
    describe(sweep, "SweepOptions");

    py::class_<DfgOptions> dfg(m, "DfgOptions");
    dfg.def(py::init<>())
        .def_readwrite("size", &DfgOptions::size)
        .def_readwrite("n_dot_v_count", &DfgOptions::n_dot_v_count)
        .def_readwrite("roughness_count", &DfgOptions::roughness_count)
        .def_readwrite("texel", &DfgOptions::texel)
        .def_readwrite("method", &DfgOptions::method)
        .def_readwrite("channels", &DfgOptions::channels)
        .def_readwrite("parameterization", &DfgOptions::parameterization)
        .def_readwrite("samples", &DfgOptions::samples)
        .def_readwrite("replicates", &DfgOptions::replicates)
        .def_readwrite("seed", &DfgOptions::seed)
        .def_readwrite("threads", &DfgOptions::threads)
        .def_readwrite("fast_math", &DfgOptions::fast_math);
    backend_fields(dfg);
    dfg.attr("_fields") = py::make_tuple("size", "n_dot_v_count", "roughness_count", "texel", "method", "channels",
                                         "parameterization", "samples", "replicates", "seed", "backend", "device", "threads",
                                         "fast_math");
    describe(dfg, "DfgOptions");

    py::class_<EnvironmentSource> environment(m, "EnvironmentSource");
    environment.def(py::init<>())
        .def_readwrite("image", &EnvironmentSource::image)
        .def_readwrite("faces", &EnvironmentSource::faces);
    environment.attr("_fields") = py::make_tuple("image", "faces");
    describe(environment, "EnvironmentSource");

    py::class_<PrefilterOptions> prefilter(m, "PrefilterOptions");
    prefilter.def(py::init<>())
        .def_readwrite("environment", &PrefilterOptions::environment)
        .def_readwrite("size", &PrefilterOptions::size)
        .def_readwrite("levels", &PrefilterOptions::levels)
        .def_readwrite("mapping", &PrefilterOptions::mapping)
        .def_readwrite("tolerance", &PrefilterOptions::tolerance)
        .def_readwrite("samples", &PrefilterOptions::samples)
        .def_readwrite("max_samples", &PrefilterOptions::max_samples)
        .def_readwrite("replicates", &PrefilterOptions::replicates)
        .def_readwrite("seed", &PrefilterOptions::seed)
        .def_readwrite("fis", &PrefilterOptions::fis)
        .def_readwrite("lod_bias", &PrefilterOptions::lod_bias)
        .def_readwrite("bright", &PrefilterOptions::bright)
        .def_readwrite("bright_threshold", &PrefilterOptions::bright_threshold)
        .def_readwrite("bright_min_roughness", &PrefilterOptions::bright_min_roughness)
        .def_readwrite("wide_samples_factor", &PrefilterOptions::wide_samples_factor)
        .def_readwrite("bright_max", &PrefilterOptions::bright_max)
        .def_readwrite("device", &PrefilterOptions::device)
        .def_readwrite("threads", &PrefilterOptions::threads)
        .def_readwrite("verify", &PrefilterOptions::verify)
        .def_readwrite("irradiance_size", &PrefilterOptions::irradiance_size);
    prefilter.attr("_fields") = py::make_tuple(
        "environment", "size", "levels", "mapping", "tolerance", "samples", "max_samples", "replicates", "seed", "fis",
        "lod_bias", "bright", "bright_threshold", "bright_min_roughness", "wide_samples_factor", "bright_max", "device",
        "threads", "verify", "irradiance_size");
    describe(prefilter, "PrefilterOptions");

    py::class_<IrradianceOptions> irradiance(m, "IrradianceOptions");
    irradiance.def(py::init<>())
        .def_readwrite("environment", &IrradianceOptions::environment)
        .def_readwrite("face_size", &IrradianceOptions::face_size)
        .def_readwrite("source_size", &IrradianceOptions::source_size)
        .def_readwrite("threads", &IrradianceOptions::threads)
        .def_readwrite("verify", &IrradianceOptions::verify);
    backend_fields(irradiance);
    irradiance.attr("_fields") =
        py::make_tuple("environment", "face_size", "source_size", "backend", "device", "threads", "verify");
    describe(irradiance, "IrradianceOptions");

    py::class_<AreaOptions> area(m, "AreaOptions");
    area.def(py::init<>()).def_readwrite("sampling", &AreaOptions::sampling);
    enum_field(area, "lobe", &AreaOptions::lobe, lobe_names());
    area.attr("_fields") = py::make_tuple("lobe", "sampling");
    describe(area, "AreaOptions");

    py::class_<SceneOptions> scene(m, "SceneOptions");
    scene.def(py::init<>())
        .def_readwrite("tolerance", &SceneOptions::tolerance)
        .def_readwrite("luts", &SceneOptions::luts)
        .def_readwrite("skip", &SceneOptions::skip)
        .def_readwrite("seed_luts", &SceneOptions::seed_luts)
        .def_readwrite("strict_domain", &SceneOptions::strict_domain)
        .def_readwrite("fast_math", &SceneOptions::fast_math);
    optional_enum_field(scene, "method", &SceneOptions::method, method_names());
    backend_fields(scene);
    scene.attr("_fields") = py::make_tuple("tolerance", "method", "luts", "skip", "seed_luts", "strict_domain", "backend",
                                           "device", "fast_math");
    describe(scene, "SceneOptions");

    py::class_<DesignOptions> design(m, "DesignOptions");
    design.def(py::init<>())
        .def_readwrite("reference", &DesignOptions::reference)
        .def_readwrite("fit_reference", &DesignOptions::fit_reference)
        .def_readwrite("cache", &DesignOptions::cache)
        .def_readwrite("luts", &DesignOptions::luts)
        .def_readwrite("reprs", &DesignOptions::reprs)
        .def_readwrite("closed_forms", &DesignOptions::closed_forms)
        .def_readwrite("fit_orders", &DesignOptions::fit_orders)
        .def_readwrite("max_bytes", &DesignOptions::max_bytes)
        .def_readwrite("max_fetches", &DesignOptions::max_fetches)
        .def_readwrite("max_alu", &DesignOptions::max_alu)
        .def_readwrite("choose", &DesignOptions::choose)
        .def_readwrite("analytic", &DesignOptions::analytic)
        .def_readwrite("strict_domain", &DesignOptions::strict_domain);
    backend_fields(design);
    design.attr("_fields") =
        py::make_tuple("reference", "fit_reference", "cache", "luts", "reprs", "closed_forms", "fit_orders", "max_bytes",
                       "max_fetches", "max_alu", "choose", "analytic", "strict_domain", "backend", "device");
    describe(design, "DesignOptions");
}

AoWeighting parse_ao_weighting(const std::string& text) { return parse("ao_weighting", text, ao_weighting_names()); }

}  // namespace microshadow_python
