// evaluate(), the isotropic query and lookup-input conversions and the analytic terms: rows of numpy
// arrays in, rows out (the Python package broadcasts and checks the arguments first).
#include "bindings.hpp"

namespace microshadow_python {
namespace {

// (N, 9) rows of visibility, alpha_x, alpha_y, wi (3), wo (3) -> (N, 2) of term, std_error.
py::array_t<double> evaluate_rows(const Doubles& rows, const SamplingOptions& options, const py::object& progress) {
    if (rows.ndim() != 2 || rows.shape(1) != 9) throw std::invalid_argument("queries must be an (N, 9) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<Query> queries(n);
    const double* r = rows.data();
    for (std::size_t i = 0; i < n; ++i, r += 9)
        queries[i] = {r[0], r[1], r[2], {r[3], r[4], r[5]}, {r[6], r[7], r[8]}};
    const std::vector<Estimate> got = run_long(progress, [&](const Progress& p) { return evaluate(queries, options, p); });
    std::vector<double> flat(2 * n);
    for (std::size_t i = 0; i < n; ++i) {
        flat[2 * i] = got[i].value;
        flat[2 * i + 1] = got[i].std_error;
    }
    return to_array(flat, {py::ssize_t(n), 2});
}

// (N, 9) query rows -> (N, 5) rows of visibility, n_dot_l, n_dot_v, roughness, relative azimuth (degrees).
py::array_t<double> lookup_input_rows(const Doubles& rows) {
    if (rows.ndim() != 2 || rows.shape(1) != 9) throw std::invalid_argument("queries must be an (N, 9) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<double> flat(5 * n);
    const double* r = rows.data();
    for (std::size_t i = 0; i < n; ++i, r += 9) {
        const LookupInputs in = lookup_inputs({r[0], r[1], r[2], {r[3], r[4], r[5]}, {r[6], r[7], r[8]}});
        const double row[5] = {in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.relative_azimuth_deg};
        std::memcpy(&flat[5 * i], row, sizeof row);
    }
    return to_array(flat, {py::ssize_t(n), 5});
}

// (N, 5) rows of visibility, n_dot_l, n_dot_v, roughness, relative azimuth (degrees), the order of
// every isotropic call (and of lookup_rows) -> (N, 9) query rows, by isotropic_query.
py::array_t<double> isotropic_rows(const Doubles& params) {
    if (params.ndim() != 2 || params.shape(1) != 5) throw std::invalid_argument("params must be an (N, 5) array");
    const std::size_t n = std::size_t(params.shape(0));
    std::vector<double> flat(9 * n);
    const double* p = params.data();
    for (std::size_t i = 0; i < n; ++i, p += 5) {
        const Query q = isotropic_query(p[0], p[1], p[2], Roughness(p[3]), p[4]);
        const double row[9] = {q.visibility, q.alpha_x, q.alpha_y, q.wi.x, q.wi.y, q.wi.z, q.wo.x, q.wo.y, q.wo.z};
        std::memcpy(&flat[9 * i], row, sizeof row);
    }
    return to_array(flat, {py::ssize_t(n), 9});
}

// (N, 4) rows of visibility, n_dot_l, n_dot_v, roughness -> (N,) values of the analytic term.
py::array_t<double> analytic_rows(const std::string& name, const Doubles& rows, const std::string& ao_weighting) {
    if (rows.ndim() != 2 || rows.shape(1) != 4) throw std::invalid_argument("analytic rows must be an (N, 4) array");
    const std::size_t n = std::size_t(rows.shape(0));
    std::vector<AnalyticInputs> inputs(n);
    const double* r = rows.data();
    for (std::size_t i = 0; i < n; ++i, r += 4) inputs[i] = {r[0], r[1], r[2], r[3]};
    return to_array(analytic_term(name, inputs, parse_ao_weighting(ao_weighting)), {py::ssize_t(n)});
}

}  // namespace

void bind_evaluate(py::module_& m) {
    m.def("evaluate_rows", &evaluate_rows, "rows"_a, "options"_a, "progress"_a);
    m.def("isotropic_rows", &isotropic_rows, "params"_a);
    m.def("lookup_input_rows", &lookup_input_rows, "rows"_a);
    m.def("analytic_term_names", &analytic_term_names);
    m.def("analytic_rows", &analytic_rows, "name"_a, "rows"_a, "ao_weighting"_a);
}

}  // namespace microshadow_python
