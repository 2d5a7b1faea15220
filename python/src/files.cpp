// LUT and representation files: open_file(), their lookups as a renderer samples them, their texels
// and metadata, and save().
#include "bindings.hpp"

namespace microshadow_python {
namespace {

double lookup_one(const LookupFile& f, const double* r) { return f.lookup(r[0], r[1], r[2], Roughness(r[3]), r[4]); }
double lookup_one(const Lut& f, const double* r) { return f.lookup(r[0], r[1], r[2], Roughness(r[3])); }

// (N, 5) rows of visibility, n_dot_l, n_dot_v, roughness, relative azimuth (degrees) -> (N,) lookups
// (a LUT ignores the azimuth).
template <class Table>
py::array_t<double> lookup_rows(const Table& file, const Doubles& rows) {
    if (rows.ndim() != 2 || rows.shape(1) != 5) throw std::invalid_argument("lookup rows must be an (N, 5) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<double> out(n);
    const double* r = rows.data();
    {
        py::gil_scoped_release release;
        for (std::size_t i = 0; i < n; ++i, r += 5) {
            try {
                out[i] = lookup_one(file, r);
            } catch (const std::domain_error& e) {
                throw std::domain_error("lookup " + std::to_string(i) + ": " + e.what());
            }
        }
    }
    return to_array(out, {py::ssize_t(n)});
}

}  // namespace

void bind_files(py::module_& m) {
    py::class_<LookupFile>(m, "LookupFile")
        .def_property_readonly("kind", &LookupFile::kind)
        .def_property_readonly("keeps_azimuth", &LookupFile::keeps_azimuth)
        .def_property_readonly("metadata_json", &LookupFile::metadata_json)
        .def("lookup_rows", &lookup_rows<LookupFile>, "rows"_a)
        .def("lut", &LookupFile::lut, py::return_value_policy::copy)
        .def("texture",
             [](const LookupFile& f) {
                 return to_array(f.texture(), {py::ssize_t(f.texture_depth()), py::ssize_t(f.texture_height()),
                                               py::ssize_t(f.texture_width()), 4});
             })
        .def("save", [](const LookupFile& f, const std::string& path, bool half) {
            py::gil_scoped_release release;
            f.save(path, half);
        }, "path"_a, "half"_a = false);
    py::class_<Lut>(m, "Lut")
        .def_property_readonly("visibility_count", &Lut::visibility_count)
        .def_property_readonly("n_dot_l_count", &Lut::n_dot_l_count)
        .def_property_readonly("n_dot_v_count", &Lut::n_dot_v_count)
        .def_property_readonly("roughness", &Lut::roughness)
        .def_property_readonly("max_total_error", &Lut::max_total_error)
        .def_property_readonly("metadata_json", &Lut::metadata_json)
        .def("axis_values", &Lut::axis_values, "axis"_a)
        .def("texels",
             [](const Lut& lut) {
                 return to_array(lut.texels(), {py::ssize_t(lut.n_dot_v_count()), py::ssize_t(lut.n_dot_l_count()),
                                                py::ssize_t(lut.visibility_count()), py::ssize_t(lut.roughness().size())});
             })
        .def("lookup_rows", &lookup_rows<Lut>, "rows"_a)
        .def("save", [](const Lut& lut, const std::string& path, const std::string& encoding) {
            py::gil_scoped_release release;
            lut.save(path, encoding);
        }, "path"_a, "encoding"_a = "");
    m.def("open_file", [](const std::string& path) {
        py::gil_scoped_release release;
        return open_file(path);
    }, "path"_a);
}

}  // namespace microshadow_python
