// design(): every candidate representation against a cached reference set; pareto.csv's columns and the
// per-band metrics as numpy arrays.
#include "bindings.hpp"

namespace microshadow_python {

void bind_design(py::module_& m) {
    m.def(
        "design",
        [](const DesignOptions& options, const py::object& progress) {
            const DesignTable t = run_long(progress, [&](const Progress& p) { return design(options, p); });
            // pareto.csv's columns, and the per-band metrics as (candidates, bands) arrays.
            const std::size_t n = t.candidates.size(), bands = t.roughness_edges.size() - 1;
            py::list name, kind, storage;
            std::vector<std::uint64_t> bytes(n), fetches(n), alu(n), points(n), outside(n);
            std::vector<double> rms(n), p99(n), max_abs(n);
            std::vector<std::uint8_t> pareto(n), chosen(n), within(n);
            std::vector<double> band_rms(n * bands), band_p99(n * bands), band_max(n * bands);
            std::vector<std::uint64_t> band_points(n * bands);
            for (std::size_t i = 0; i < n; ++i) {
                const DesignCandidate& c = t.candidates[i];
                name.append(c.name);
                kind.append(c.kind);
                storage.append(c.storage);
                bytes[i] = c.bytes;
                fetches[i] = c.fetches_per_light;
                alu[i] = c.alu_per_light;
                rms[i] = c.metrics.weighted_rms;
                p99[i] = c.metrics.weighted_p99;
                max_abs[i] = c.metrics.max_abs;
                points[i] = c.metrics.points;
                pareto[i] = c.pareto;
                chosen[i] = c.chosen;
                within[i] = c.within_budget;
                outside[i] = c.outside_domain;
                for (std::size_t b = 0; b < bands; ++b) {
                    band_rms[i * bands + b] = c.by_roughness[b].weighted_rms;
                    band_p99[i * bands + b] = c.by_roughness[b].weighted_p99;
                    band_max[i * bands + b] = c.by_roughness[b].max_abs;
                    band_points[i * bands + b] = c.by_roughness[b].points;
                }
            }
            const auto np = py::module_::import("numpy");
            const auto text = [&](const py::list& l) { return np.attr("array")(l, "dtype"_a = "U"); };
            const auto flags = [&](const std::vector<std::uint8_t>& v) {
                return to_array(v, {py::ssize_t(n)}).attr("astype")("bool");
            };
            const std::vector<py::ssize_t> one{py::ssize_t(n)}, two{py::ssize_t(n), py::ssize_t(bands)};
            py::dict table;
            table["name"] = text(name);
            table["kind"] = text(kind);
            table["storage"] = text(storage);
            table["bytes"] = to_array(bytes, one);
            table["fetches_per_light"] = to_array(fetches, one);
            table["alu_per_light"] = to_array(alu, one);
            table["weighted_rms"] = to_array(rms, one);
            table["weighted_p99"] = to_array(p99, one);
            table["max_abs"] = to_array(max_abs, one);
            table["pareto"] = flags(pareto);
            table["chosen"] = flags(chosen);
            table["within_budget"] = flags(within);
            table["outside_domain"] = to_array(outside, one);
            table["points"] = to_array(points, one);
            py::dict by_roughness;
            by_roughness["edges"] = to_array(t.roughness_edges, {py::ssize_t(t.roughness_edges.size())});
            by_roughness["points"] = to_array(band_points, two);
            by_roughness["weighted_rms"] = to_array(band_rms, two);
            by_roughness["weighted_p99"] = to_array(band_p99, two);
            by_roughness["max_abs"] = to_array(band_max, two);
            py::dict reference_set;
            reference_set["file"] = t.reference_file;
            reference_set["points"] = t.reference_points;
            reference_set["max_std_error"] = t.reference_max_std_error;
            reference_set["rms_std_error"] = t.reference_rms_std_error;
            return py::make_tuple(table, by_roughness, t.chosen, reference_set);
        },
        "options"_a, "progress"_a);
}

}  // namespace microshadow_python
