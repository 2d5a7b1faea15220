// bake() and repr_bake(): a LUT or a representation from its options struct (the package builds it from
// the keyword arguments, python/microshadow/_options.py).
#include "bindings.hpp"

namespace microshadow_python {

void bind_bake(py::module_& m) {
    m.def(
        "bake",
        [](const BakeOptions& options, const py::object& progress) {
            return run_long(progress, [&](const Progress& p) { return bake(options, p); });
        },
        "options"_a, "progress"_a);
    m.def(
        "repr_bake",
        [](const ReprBakeOptions& options, const py::object& progress) {
            return run_long(progress, [&](const Progress& p) { return repr_bake(options, p); });
        },
        "options"_a, "progress"_a);
}

}  // namespace microshadow_python
