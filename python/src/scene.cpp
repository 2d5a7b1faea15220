// scene(): every pixel of a scene against the approximations, its layers as numpy arrays.
#include "bindings.hpp"

namespace microshadow_python {

void bind_scene(py::module_& m) {
    py::class_<SceneResult>(m, "SceneResult")
        .def_property_readonly("width", &SceneResult::width)
        .def_property_readonly("height", &SceneResult::height)
        .def_property_readonly("lights", &SceneResult::lights)
        .def_property_readonly("comparators", &SceneResult::comparators)
        .def_property_readonly("report_json", &SceneResult::report_json)
        .def("layers",
             [](const SceneResult& r) {
                 py::dict out;
                 for (const SceneLayer& l : r.layers())
                     out[py::str(l.name)] = to_array(l.pixels, {py::ssize_t(r.height()), py::ssize_t(r.width())});
                 return out;
             })
        .def("save", [](const SceneResult& r, const std::string& dir) {
            py::gil_scoped_release release;
            r.save(dir);
        }, "dir"_a);
    m.def(
        "scene",
        [](const std::string& path, const SceneOptions& options, const py::object& progress) {
            return run_long(progress, [&](const Progress& p) { return scene(path, options, p); });
        },
        "path"_a, "options"_a, "progress"_a);
}

}  // namespace microshadow_python
