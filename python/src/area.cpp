// area_evaluate(): the term over sphere and rectangle lights, from rows of surface and light columns.
#include "bindings.hpp"

namespace microshadow_python {
namespace {

// (N, 6) rows of visibility, alpha_x, alpha_y, wi (3) and (N, 4) sphere rows (centre (3), half-angle in
// degrees) or (N, 12) rectangle rows (the corners) -> the queries of area_evaluate.
std::vector<AreaQuery> area_queries(const Doubles& surface, const Doubles& light, LightShape shape) {
    const py::ssize_t light_columns = shape == LightShape::sphere ? 4 : 12;
    if (surface.ndim() != 2 || surface.shape(1) != 6) throw std::invalid_argument("surface rows must be an (N, 6) array");
    if (light.ndim() != 2 || light.shape(1) != light_columns || light.shape(0) != surface.shape(0))
        throw std::invalid_argument("light rows must be (N, " + std::to_string(light_columns) + ")");
    const std::size_t n = std::size_t(surface.shape(0));
    std::vector<AreaQuery> queries(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double* s = surface.data() + 6 * i;
        const double* l = light.data() + light_columns * i;
        AreaQuery& q = queries[i];
        q.visibility = s[0];
        q.alpha_x = s[1];
        q.alpha_y = s[2];
        q.wi = {s[3], s[4], s[5]};
        q.light = shape;
        if (shape == LightShape::sphere) {
            q.light_direction = {l[0], l[1], l[2]};
            q.half_angle_deg = l[3];
        } else {
            for (int k = 0; k < 4; ++k) q.corners[k] = {l[3 * k], l[3 * k + 1], l[3 * k + 2]};
        }
    }
    return queries;
}

}  // namespace

void bind_area(py::module_& m) {
    m.def(
        "area_evaluate",
        [](const Doubles& surface, const Doubles& light, const std::string& shape, const AreaOptions& options,
           const py::object& progress) {
            if (shape != "sphere" && shape != "rect") throw std::invalid_argument("light = '" + shape + "' (sphere or rect)");
            const std::vector<AreaQuery> queries = area_queries(surface, light, shape == "sphere" ? LightShape::sphere : LightShape::rect);
            const std::vector<AreaEstimate> got =
                run_long(progress, [&](const Progress& p) { return area_evaluate(queries, options, p); });
            std::vector<double> flat(3 * got.size());
            for (std::size_t i = 0; i < got.size(); ++i) {
                flat[3 * i] = got[i].value;
                flat[3 * i + 1] = got[i].std_error;
                flat[3 * i + 2] = got[i].inner_error;
            }
            return to_array(flat, {py::ssize_t(got.size()), 3});
        },
        "surface"_a, "light"_a, "shape"_a, "options"_a, "progress"_a);
}

}  // namespace microshadow_python
