// microshadow._microshadow: the pybind11 layer over the public C++ API (<microshadow/microshadow.hpp>).
// Each job's binding is a file of its own (bindings.hpp lists them); the option structs are bound once
// (options.cpp) and every job takes its struct, as the C++ API does. The argument checks that name the
// argument and index, the broadcasting and the documentation live in the Python package
// (python/microshadow/).
#include "bindings.hpp"

PYBIND11_MODULE(_microshadow, m) {
    namespace msp = microshadow_python;
    m.doc() = "microshadow's C++ engine (use the microshadow package, which checks and documents the arguments)";
    m.def("version", &microshadow::version);
    msp::bind_options(m);
    msp::bind_evaluate(m);
    msp::bind_files(m);
    msp::bind_bake(m);
    msp::bind_sweep(m);
    msp::bind_ibl(m);
    msp::bind_area(m);
    msp::bind_scene(m);
    msp::bind_design(m);
}
