// sweep(): a parameter study from a spec file or TOML text, its sweep.csv as a dict of numpy arrays.
#include "bindings.hpp"

namespace microshadow_python {
namespace {

py::dict table_dict(const SweepTable& t) {
    py::dict out;
    for (std::size_t k = 0; k < t.columns.size(); ++k) {
        if (!t.texts[k].empty() || t.numbers[k].empty()) {
            py::list texts;
            for (const auto& s : t.texts[k]) texts.append(s);
            out[py::str(t.columns[k])] = py::module_::import("numpy").attr("array")(texts, "dtype"_a = "U");
        } else {
            out[py::str(t.columns[k])] = to_array(t.numbers[k], {py::ssize_t(t.numbers[k].size())});
        }
    }
    return out;
}

}  // namespace

void bind_sweep(py::module_& m) {
    m.def(
        "sweep",
        [](const std::string& spec_path, const std::string& toml, const std::string& base_dir, const SweepOptions& options,
           const py::object& progress) {
            const SweepTable table = run_long(progress, [&](const Progress& p) {
                return spec_path.empty() ? sweep_toml(toml, base_dir, options, p) : sweep(spec_path, options, p);
            });
            return py::make_tuple(table_dict(table), table.summary_markdown);
        },
        "spec_path"_a, "toml"_a, "base_dir"_a, "options"_a, "progress"_a);
}

}  // namespace microshadow_python
