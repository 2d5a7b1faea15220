// The image-based lighting integrals: the DFG LUT, the prefiltered environment, the irradiance map and
// spherical harmonics, each as a class with its arrays, metadata and save().
#include "bindings.hpp"

namespace microshadow_python {
namespace {

// A cubemap as a (6, size, size, 3) float32 array (faces +X -X +Y -Y +Z -Z).
py::array_t<float> cube_array(const CubeImage& c) {
    return to_array(c.texels, {6, py::ssize_t(c.size), py::ssize_t(c.size), 3});
}

}  // namespace

void bind_ibl(py::module_& m) {
    py::class_<DfgLut>(m, "DfgLut")
        .def_property_readonly("metadata_json", &DfgLut::metadata_json)
        .def_property_readonly("n_dot_v", &DfgLut::n_dot_v_values)
        .def_property_readonly("roughness", &DfgLut::roughness_values)
        .def_property_readonly("channels", &DfgLut::channels)
        .def("values", [](const DfgLut& d) {
            return to_array(d.values(), {py::ssize_t(d.roughness_count()), py::ssize_t(d.n_dot_v_count()),
                                         py::ssize_t(d.channels().size())});
        })
        .def("std_errors", [](const DfgLut& d) {
            return to_array(d.std_errors(), {py::ssize_t(d.roughness_count()), py::ssize_t(d.n_dot_v_count()),
                                             py::ssize_t(d.channels().size())});
        })
        .def("save", [](const DfgLut& d, const std::string& path, bool half, const std::string& symbol) {
            py::gil_scoped_release release;
            d.save(path, half, symbol);
        }, "path"_a, "half"_a = false, "symbol"_a = "microshadow_dfg");
    m.def(
        "bake_dfg",
        [](const DfgOptions& options, const py::object& progress) {
            return run_long(progress, [&](const Progress& p) { return bake_dfg(options, p); });
        },
        "options"_a, "progress"_a);

    py::class_<PrefilteredEnvironment>(m, "PrefilteredEnvironment")
        .def_property_readonly("mip_roughness", &PrefilteredEnvironment::mip_roughness)
        .def_property_readonly("metadata_json", &PrefilteredEnvironment::metadata_json)
        .def("mips",
             [](const PrefilteredEnvironment& p) {
                 py::list out;
                 for (std::size_t k = 0; k < p.mip_count(); ++k) out.append(cube_array(p.mip(k)));
                 return out;
             })
        .def("irradiance", [](const PrefilteredEnvironment& p) { return cube_array(p.irradiance()); })
        .def("sh", [](const PrefilteredEnvironment& p) { return to_array(p.sh(), {9, 3}); })
        .def("save", [](const PrefilteredEnvironment& p, const std::string& dir, const std::string& format,
                        const std::string& encoding, double exposure) {
            py::gil_scoped_release release;
            p.save(dir, format, encoding, exposure);
        }, "dir"_a, "format"_a, "encoding"_a, "exposure"_a);
    m.def(
        "prefilter",
        [](const PrefilterOptions& options, const py::object& progress) {
            return run_long(progress, [&](const Progress& p) { return prefilter(options, p); });
        },
        "options"_a, "progress"_a);

    py::class_<IrradianceMap>(m, "IrradianceMap")
        .def_property_readonly("metadata_json", &IrradianceMap::metadata_json)
        .def("map", [](const IrradianceMap& r) { return cube_array(r.map()); })
        .def("bound", [](const IrradianceMap& r) { return cube_array(r.bound()); })
        .def("save", [](const IrradianceMap& r, const std::string& dir, const std::string& format, const std::string& encoding,
                        double exposure) {
            py::gil_scoped_release release;
            r.save(dir, format, encoding, exposure);
        }, "dir"_a, "format"_a, "encoding"_a, "exposure"_a);
    m.def(
        "irradiance",
        [](const IrradianceOptions& options, const py::object& progress) {
            return run_long(progress, [&](const Progress& p) { return irradiance(options, p); });
        },
        "options"_a, "progress"_a);

    py::class_<ShIrradiance>(m, "ShIrradiance")
        .def_property_readonly("metadata_json", &ShIrradiance::metadata_json)
        .def("sh", [](const ShIrradiance& r) { return to_array(r.sh(), {9, 3}); })
        .def("irradiance", [](const ShIrradiance& r) { return cube_array(r.irradiance()); })
        .def("save", [](const ShIrradiance& r, const std::string& json, const std::string& irradiance, const std::string& preview,
                        const std::string& shader, const std::string& symbol) {
            py::gil_scoped_release release;
            r.save(json, irradiance, preview, shader, symbol);
        }, "json"_a, "irradiance"_a, "preview"_a, "shader"_a, "symbol"_a);
    m.def("spherical_harmonics", [](const EnvironmentSource& environment, std::uint32_t face_size) {
        py::gil_scoped_release release;
        return spherical_harmonics(environment, face_size);
    }, "environment"_a, "face_size"_a);
}

}  // namespace microshadow_python
