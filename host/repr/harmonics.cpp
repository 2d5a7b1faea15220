// "azimuth-harmonics": per texel a cosine series in the relative azimuth.
//
// Derivation. The term is an even, 2 pi-periodic, smooth function of phi, so it has a cosine series
// f(phi) = sum_m a_m cos(m phi). From the K bake nodes phi_k = pi k / N (N = K - 1 intervals) the
// trapezoid-weighted sums are discretely orthogonal (the DCT-I): with w_k = 1/2 at k = 0 and N, else 1,
//   sum_k w_k cos(m phi_k) cos(m' phi_k) = N (m = m' = 0), N / 2 (m = m' in 1..N-1), 0 (m != m'),
// so the projection a_0 = (1/N) sum_k w_k f_k, a_m = (2/N) sum_k w_k f_k cos(m phi_k) is the series
// truncated to m <= 3 (exact when the term has no higher harmonics; the residual at the nodes is
// recorded as "node_residual_max"). The lookup evaluates a0 + a1 c + a2 (2c^2 - 1) + a3 (4c^3 - 3c)
// with c = cos phi (no trigonometry in the shader) and clamps the result to [0, 1].
// Under the far-side warp (ReprGrid::azimuth_warp) c is replaced by the warped coordinate y(cos phi)
// and each texel's node k sits where y = cos(pi k / N): the same sums are then the Chebyshev
// coefficients of the interpolant in y, and the lookup evaluates them at the query's own y.
//
// Layout: a 3D texture of width nv (visibility), height nl (NdotL), depth nvv * R: roughness node j
// occupies depth slices [j nvv, (j + 1) nvv); RGBA = (a0, a1, a2, a3). The NdotV coordinate is clamped
// inside its slab, so the filter never reads the next roughness. Two fetches per light: the slabs of the
// two roughness nodes that bracket the roughness, each trilinearly filtered, blended by hand.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "repr/texture_repr.hpp"

namespace ms::repr {

namespace {

constexpr int kHarmonics = 4;

class AzimuthHarmonics final : public TextureRepresentation {
public:
    using TextureRepresentation::TextureRepresentation;
    std::string kind() const override { return "azimuth-harmonics"; }
    std::string name() const override {
        std::ostringstream o;
        o << "azimuth harmonics a0..a3: " << grid_.visibility << " visibility (" << to_string(grid_.warps.visibility) << ") x " << grid_.n_dot_l << " NdotL ("
          << to_string(grid_.warps.n_dot_l) << ") x " << grid_.n_dot_v << " NdotV (" << to_string(grid_.warps.n_dot_v)
          << ") x " << grid_.roughness.size() << " roughness slabs:";
        for (double r : grid_.roughness) o << " " << r;
        return o.str();
    }
    std::vector<std::string> channel_names() const override { return {"cos0phi", "cos1phi", "cos2phi", "cos3phi"}; }
    // With f_k in [0, 1] and sum_k w_k = N: a_0 = (1/N) sum w_k f_k is in [0, 1] and
    // |a_m| <= (2/N) sum w_k |f_k cos(m phi_k)| <= 2.
    std::array<double, 2> channel_range(std::size_t c) const override {
        return c == 0 ? std::array<double, 2>{0.0, 1.0} : std::array<double, 2>{-2.0, 2.0};
    }

    double operator()(const approx::Inputs& in) const override {
        if (zero_region(in.visibility, in.n_dot_l)) return 0;
        // Full visibility: the cone is the whole hemisphere and the term is exactly 1 above the horizon.
        // Just below v = 1 a light under the cone's edge sqrt(1 - v) is still shadowed, so no texel
        // holds both sides of that limit.
        if (in.visibility >= 1) return 1;
        const double tv = visibility_texel(in.visibility), tz = n_dot_v_texel(in.n_dot_v);
        const double c = grid_.azimuth_coordinate(std::cos(in.relative_azimuth), in.n_dot_v, in.n_dot_l);
        const double basis[kHarmonics] = {1, c, 2 * c * c - 1, (4 * c * c - 3) * c};
        // The NdotL texel of a slab: its own under the edge-roughness warp, else one for all.
        auto series = [&](std::uint32_t slab) {
            const double tl = n_dot_l_texel(in.visibility, in.n_dot_l, slab);
            const auto a = texture_.sample(tv, tl, double(slab) * grid_.n_dot_v + tz);
            double s = 0;
            for (int m = 0; m < kHarmonics; ++m) s += a[m] * basis[m];
            return s;
        };
        const auto& r = grid_.roughness;
        if (r.size() == 1) return std::clamp(series(0), 0.0, 1.0);
        const double x = std::clamp(in.roughness, r.front(), r.back());
        std::size_t j = 0;
        while (j + 2 < r.size() && x > r[j + 1]) ++j;
        const double f = (x - r[j]) * (1 / (r[j + 1] - r[j]));
        const double a = series(std::uint32_t(j)), b = series(std::uint32_t(j + 1));
        return std::clamp(a + (b - a) * f, 0.0, 1.0);
    }

    // The far-side warp written out (ReprGrid::azimuth_coordinate): c becomes the series coordinate y.
    std::string azimuth_warp_text() const {
        if (!(grid_.azimuth_warp > 0)) return "";
        const auto L = shader_literal;
        return "    // The series is in y = 2 asinh((1 + c) / tau) / asinh(2 / tau) - 1, tau = kappa (NdotV + NdotL)^2 / 2:\n"
               "    // its range spent near the far side, where a light at the horizon falls into shadow.\n"
               "    float d_w = max(n_dot_v, 0.0) + max(n_dot_l, 0.0);\n"
               "    float tau = max(" + L(grid_.azimuth_warp / 2) + " * d_w * d_w, " + L(1e-6) + ");\n"
               "    c = 2.0 * ms_asinh((1.0 + c) / tau) / ms_asinh(2.0 / tau) - 1.0;\n";
    }

    std::string shader(ShaderLanguage language, const std::string& source_name) const override {
        const auto L = shader_literal;
        const auto& r = grid_.roughness;
        std::ostringstream o;
        o << shader_common(source_name);
        o << "// RGBA = a0..a3 of a0 + a1 cos(phi) + a2 cos(2 phi) + a3 cos(3 phi); depth = roughness slab j * "
          << grid_.n_dot_v << " + NdotV texel, slabs at roughness";
        for (double x : r) o << " " << x;
        o << ".\n";
        o << "ENTRY(float visibility, float n_dot_l, float n_dot_v, float roughness, float cos_phi)\n{\n"
          << "    if (ms_zero_region(visibility, n_dot_l)) return 0.0;  // early-out: no fetch\n"
          << "    if (visibility >= 1.0) return 1.0;  // the cone is the hemisphere: lit wherever above the horizon\n"
          << shader_coordinates()
          << "    float c = clamp(cos_phi, -1.0, 1.0);\n" << azimuth_warp_text()
          << "    // cos(2 phi) and cos(3 phi) from cos(phi) (Chebyshev polynomials): no trigonometry.\n"
          << "    VEC4 basis = VEC4(1.0, c, 2.0 * c * c - 1.0, (4.0 * c * c - 3.0) * c);\n";
        const bool edge = grid_.warps.n_dot_l == NdotLWarp::edge_roughness;
        // The edge warp's width of a node: k alpha max(s_e, alpha), alpha = r^2.
        auto width = [&](double x) { return L(grid_.edge_width * x * x) + " * max(s_e, " + L(x * x) + ")"; };
        if (r.size() == 1) {
            if (edge) o << "    float tl = ms_edge_texel(n_dot_l, c_e, l0, " << width(r[0]) << ");\n";
            o << "    VEC3 c0 = VEC3((tv + 0.5) * " << L(1.0 / texture_.width) << ", (tl + 0.5) * " << L(1.0 / texture_.height)
              << ", (tz + 0.5) * " << L(1.0 / texture_.depth) << ");\n"
              << "    return clamp(dot(FETCH(c0), basis), 0.0, 1.0);\n}\n";
        } else {
            // Nodes in geometric progression (r_k = r_0 q^k, as the full-range preset's): the slab from a
            // logarithm, a dozen ALU, instead of a comparison per node.
            const double q = r[1] / r[0];
            bool geometric = r.size() > 2;
            for (std::size_t k = 1; k < r.size() && geometric; ++k) geometric = std::abs(r[k] / r[k - 1] - q) <= 1e-9 * q;
            o << "    // The roughness slabs j and j + 1 that bracket the roughness, and the weight of j + 1.\n"
              << "    float r = clamp(roughness, " << L(r.front()) << ", " << L(r.back()) << ");\n";
            if (geometric) {
                o << "    // Geometric nodes r_k = " << L(r[0]) << " * " << L(q) << "^k: j = floor(log(r / r_0) / log(q)).\n"
                  << "    float j = floor(clamp(log(r * " << L(1 / r[0]) << ") * " << L(1 / std::log(q)) << ", 0.0, " << L(double(r.size() - 2))
                  << "));\n"
                  << "    float rj = " << L(r[0]) << " * exp(j * " << L(std::log(q)) << ");\n"
                  << "    float f = clamp((r - rj) / (rj * " << L(q - 1) << "), 0.0, 1.0);\n";
                if (edge)
                    o << "    float rj1 = rj * " << L(q) << ";\n"
                      << "    float al0 = rj * rj, al1 = rj1 * rj1;\n    float ka0 = " << L(grid_.edge_width) << " * al0, ka1 = "
                      << L(grid_.edge_width) << " * al1;\n";
            } else {
                o << "    float j = 0.0;\n    float f = (r - " << L(r[0]) << ") * " << L(1 / (r[1] - r[0])) << ";\n";
            }
            // Under the edge-roughness warp each slab has its own NdotL axis: its width w0, w1 too.
            // The edge warp's k alpha and alpha of nodes j and j + 1 (w = k alpha max(s_e, alpha)).
            auto ka = [&](double x) { return L(grid_.edge_width * x * x); };
            auto al = [&](double x) { return L(x * x); };
            if (edge && !geometric)
                o << "    float ka0 = " << ka(r[0]) << ", al0 = " << al(r[0]) << ", ka1 = " << ka(r[1]) << ", al1 = " << al(r[1]) << ";\n";
            for (std::size_t k = 1; k + 1 < r.size() && !geometric; ++k) {
                o << "    if (r > " << L(r[k]) << ") { j = " << L(k) << "; f = (r - " << L(r[k]) << ") * " << L(1 / (r[k + 1] - r[k]));
                if (edge) o << "; ka0 = " << ka(r[k]) << "; al0 = " << al(r[k]) << "; ka1 = " << ka(r[k + 1]) << "; al1 = " << al(r[k + 1]);
                o << "; }\n";
            }
            if (edge)
                o << "    float tl = ms_edge_texel(n_dot_l, c_e, l0, ka0 * max(s_e, al0));\n"
                  << "    float tl1 = ms_edge_texel(n_dot_l, c_e, l0, ka1 * max(s_e, al1));\n";
            o << "    VEC3 c0 = VEC3((tv + 0.5) * " << L(1.0 / texture_.width) << ", (tl + 0.5) * " << L(1.0 / texture_.height)
              << ", (j * " << L(grid_.n_dot_v) << " + tz + 0.5) * " << L(1.0 / texture_.depth) << ");\n";
            if (edge)
                o << "    VEC3 c1 = VEC3(c0.x, (tl1 + 0.5) * " << L(1.0 / texture_.height) << ", c0.z + "
                  << L(double(grid_.n_dot_v) / texture_.depth) << ");\n";
            else
                o << "    VEC3 c1 = c0 + VEC3(0.0, 0.0, " << L(double(grid_.n_dot_v) / texture_.depth) << ");\n";
            o
              << "    return clamp(MIX(dot(FETCH(c0), basis), dot(FETCH(c1), basis), f), 0.0, 1.0);\n}\n";
        }
        return finish_shader(o.str(), language);
    }
};

}  // namespace

std::unique_ptr<Representation> make_azimuth_harmonics(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                       nlohmann::json metadata) {
    if (grid.roughness.empty()) throw std::invalid_argument("azimuth-harmonics: at least 1 roughness node");
    if (texture.width != grid.visibility || texture.height != grid.n_dot_l || texture.depth != grid.n_dot_v * grid.roughness.size())
        throw std::invalid_argument("azimuth-harmonics: texture size does not match the grid");
    metadata["fetches_per_light"] = grid.roughness.size() == 1 ? 1 : 2;
    return std::make_unique<AzimuthHarmonics>(std::move(grid), azimuth_nodes, std::move(texture), std::move(metadata));
}

std::unique_ptr<Representation> build_azimuth_harmonics(const AzimuthBake& bake) {
    const auto& g = bake.grid;
    const std::uint32_t K = bake.azimuth_nodes, N = K - 1;
    if (K < 2 * kHarmonics - 1)
        throw std::invalid_argument("azimuth-harmonics: needs at least " + std::to_string(2 * kHarmonics - 1) + " azimuth nodes");
    Texture3D t;
    t.width = g.visibility;
    t.height = g.n_dot_l;
    t.depth = g.n_dot_v * std::uint32_t(g.roughness.size());
    t.texels.resize(std::size_t(t.width) * t.height * t.depth * 4);
    double residual = 0;
    for (std::uint32_t r = 0; r < g.roughness.size(); ++r)
        for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
            for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                    double a[kHarmonics] = {0, 0, 0, 0};
                    for (std::uint32_t k = 0; k <= N; ++k) {
                        const double w = (k == 0 || k == N) ? 0.5 : 1.0, f = bake.value[bake.index(r, k, iv, il, ivv)];
                        // cos(m pi k / N) = T_m(y_k) at the node's series coordinate y_k = cos(pi k / N).
                        for (int m = 0; m < kHarmonics; ++m) a[m] += w * f * std::cos(m * M_PI * k / N);
                    }
                    for (int m = 0; m < kHarmonics; ++m) a[m] *= (m == 0 ? 1.0 : 2.0) / N;
                    // The truncation residual at the nodes (what the series misses of the bake there).
                    for (std::uint32_t k = 0; k <= N; ++k) {
                        double s = 0;
                        for (int m = 0; m < kHarmonics; ++m) s += a[m] * std::cos(m * M_PI * k / N);
                        residual = std::max(residual, std::abs(std::clamp(s, 0.0, 1.0) - bake.value[bake.index(r, k, iv, il, ivv)]));
                    }
                    const std::size_t z = std::size_t(r) * g.n_dot_v + ivv;
                    for (int m = 0; m < kHarmonics; ++m) t.texels[((z * t.height + il) * t.width + iv) * 4 + m] = float(a[m]);
                }
    nlohmann::json meta = {{"bake", bake.metadata}, {"node_residual_max", residual}};
    for (const char* key : {"version", "command_line", "domain", "preset"})
        if (bake.metadata.contains(key)) meta[key] = bake.metadata[key];
    return make_azimuth_harmonics(g, K, std::move(t), std::move(meta));
}

}  // namespace ms::repr
