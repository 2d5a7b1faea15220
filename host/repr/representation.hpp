// Texture representations of the micro-shadowing term that keep the relative azimuth, as
// comparators a renderer could ship: each has its bake (an AzimuthBake: the term per texel at K azimuth
// nodes), its C++ lookup (the renderer's sampling, written out), its file (OpenEXR atlas with the
// metadata in the "microshadow" header attribute, "kind": "representation"), its generated GLSL/HLSL
// (matching the C++ lookup; tests/gpu/repr_shader_test.cpp runs it on lavapipe) and its cost model.
// docs/representations.md derives each one and gives its measured error.
//
// Kinds:
// - "azimuth-axis": 4D (visibility, NdotL, NdotV, azimuth) in one 3D texture: K azimuth slots of
//   nv visibility texels side by side along x, NdotL along y, NdotV along z, one roughness per RGBA
//   channel. Two filtered fetches (the two azimuth slots that bracket phi), blended by hand.
// - "azimuth-harmonics": per texel a0 + a1 cos(phi) + a2 cos(2 phi) + a3 cos(3 phi) in RGBA (the
//   discrete cosine projection of the K nodes), roughness slabs stacked along z. Two fetches (the two
//   roughness slabs that bracket the roughness), blended by hand.
// Both take the warped axes (Warps) and roughness nodes chosen by error (choose_roughness_nodes).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/lookup_domain.hpp"
#include "core/types.hpp"
#include "approx/approximation.hpp"
#include "lut/formats/texture.hpp"
#include "lut/formats/texture_format.hpp"
#include "lut/shader/language.hpp"

namespace ms::repr {

using ShaderLanguage = lutshader::ShaderLanguage;  // glsl, hlsl

// Axis warps: the texture coordinate of a parameter. Texel i of an n-texel axis sits at warped
// coordinate u = (i + 0.5) / n (texel centres over [0, 1]).
//   NdotV: linear u = NdotV, or sqrt u = sqrt(NdotV) (HDRP's FGD table): more texels at grazing views.
//   NdotL: linear u = NdotL, or shadow_edge u = (NdotL - l0(v)) / (1 - l0(v)) with
//          l0(v) = max(0, edge(v)), edge(v) = 1 - 2v (cosine AO) or 2 (1 - v)^2 - 1 (uniform AO): the
//          provable zero region NdotL <= edge(v) holds no texel; or sqrt_top u = 1 - sqrt(1 - NdotL):
//          texels dense near NdotL = 1, where the term is smooth in the light's angle, not in its cosine.
//          Or edge_roughness (harmonics only): per roughness slab r, NdotL measured from the shadow edge
//          NdotL = c(v) (the cone's cosine: sqrt(1 - v) cosine AO, 1 - v uniform) in units of the slab's
//          edge width w = k alpha max(sin theta_c, alpha) (alpha = r^2, sin theta_c = sqrt(1 - c^2)),
//          through g(x) = asinh((x - c) / w):
//          u = (g(NdotL) - g(l0(v))) / (g(1) - g(l0(v))). A smooth surface's term is a step at NdotL = c
//          blurred over a width ~ alpha; this puts the same share of a slab's texels on that blur at
//          every roughness (asinh: linear within w of the edge, logarithmic beyond), so low roughness is
//          resolved where a linear axis would jump from 0 to 1 in one texel.
//   visibility: linear u = v, or sqrt_top u = 1 - sqrt(1 - v): texels dense near v = 1, where the term
//          rises to exactly 1 and is smooth in sqrt(1 - v) (the cosine AO cone's cos theta), not in v.
//          Or edge_roughness (harmonics with the edge-roughness NdotL warp only): per roughness slab r and
//          the query's NdotV, texels evenly in H(c) = 1 - sqrt(1 - c) + beta asinh(c / s) / asinh(1 / s)
//          of the cone's cosine c, s = b min(alpha, kappa NdotV), from visibility_start (else v = 0) down
//          to v = 1 (H = 0). As the cone's edge nears the horizon (c of a few s) the shadow below it goes
//          and the term rises to 1: over c ~ alpha for a smooth surface, ~ NdotV / 4 for a grazing view on
//          the far side; the asinh spends beta / (1 + beta) of the texels there, logarithmically, and
//          1 - sqrt(1 - c) is uniform in the cone's angle near v = 0, where the narrow cone changes fast.
enum class NdotVWarp { linear, sqrt };
enum class NdotLWarp { linear, shadow_edge, sqrt_top, edge_roughness };
enum class VisibilityWarp { linear, sqrt_top, edge_roughness };
// Where the NdotL and NdotV texels sit on their warped axes: at cell centres u = (i + 0.5) / n (the
// lookup clamps to the first and last centres, so the axis's last half texel at either end repeats
// them), or at the ends u = i / (n - 1): the first and last texels lie on the axis's ends (NdotL: the
// zero region's edge and NdotL = 1; NdotV: n_dot_v_start and 1), so no lookup inside the domain reads
// past a texel. The visibility axis keeps its centres (the term is 1 at v = 1, which the lookup answers
// by rule, and the edge-roughness NdotL coordinate follows the query's own visibility).
enum class TexelPlacement { centres, ends };
struct Warps {
    NdotVWarp n_dot_v = NdotVWarp::linear;
    NdotLWarp n_dot_l = NdotLWarp::linear;
    VisibilityWarp visibility = VisibilityWarp::linear;
};
std::string to_string(NdotVWarp);
std::string to_string(NdotLWarp);
std::string to_string(VisibilityWarp);
std::string to_string(TexelPlacement);
TexelPlacement parse_texel_placement(const std::string&);  // "centres" | "ends"; std::invalid_argument
NdotVWarp parse_n_dot_v_warp(const std::string&);  // "linear" | "sqrt"; std::invalid_argument
NdotLWarp parse_n_dot_l_warp(const std::string&);  // "linear" | "shadow-edge" | "sqrt-top" | "edge-roughness"; std::invalid_argument
VisibilityWarp parse_visibility_warp(const std::string&);  // "linear" | "sqrt-top"; std::invalid_argument

// The least NdotV the view-dependent widths and scales read (they scale with it): keeps them above 0.
constexpr double kViewFloor = 1e-3;

// The texel grid every representation is baked on: visibility, NdotL and NdotV texel centres in
// warped coordinates and the roughness nodes.
struct ReprGrid {
    std::uint32_t visibility = 16, n_dot_l = 16, n_dot_v = 16;
    std::vector<double> roughness{0.1, 0.4, 0.7, 1.0};
    Warps warps;
    AoWeighting weighting = AoWeighting::cosine;
    // The edge_roughness warp's width factor k (w = k alpha max(sin theta_c, alpha)).
    double edge_width = 2.0;
    // NdotL and NdotV texel placement, and with `ends` the NdotV of the first texel: the NdotV axis
    // u = (w(NdotV) - w(start)) / (1 - w(start)) for its warp w, so no texel lies below the domain.
    TexelPlacement placement = TexelPlacement::centres;
    double n_dot_v_start = 0;
    // The azimuth-harmonics' far-side warp kappa (0: none, the series in cos phi). With kappa > 0 the
    // series is in y = 2 asinh((1 + cos phi) / tau) / asinh(2 / tau) - 1, tau = kappa (NdotV + NdotL)^2 / 2
    // (at least 1e-6): with the light near the horizon on the far side of a grazing view the term falls
    // to 0 within an azimuth of ~ NdotV + NdotL of phi = pi (where the great circles normal to V and to
    // L nearly meet), a width 1 + cos phi ~ tau that a cubic in cos phi cannot follow; y spends its
    // range there, logarithmically beyond, and is cos phi itself as tau grows large.
    double azimuth_warp = 0;
    // The visibility of the first visibility texel (0: the first cell centre). With a start the texels
    // run evenly in the warped coordinate from it to the last cell centre, so the domain's lowest
    // visibility, where the term changes fastest with v, is not clamped to a texel above it.
    double visibility_start = 0;
    // The edge-roughness visibility warp's constants (VisibilityWarp::edge_roughness): the share beta of
    // the axis spent logarithmically, the width factor b and the view factor kappa of its scale
    // s = b min(alpha, kappa NdotV) (kappa = 0: s = b alpha). Read only by that warp.
    double visibility_edge_share = 0.4, visibility_edge_width = 0.5, visibility_edge_view = 0.25;
    // The edge-roughness NdotL warp's view factor kappa (0: none): the width w is at most
    // kappa (NdotV + c) (the shadow's scale in NdotL where a grazing view meets a cone edge near the horizon).
    double n_dot_l_edge_view = 0;
    // tau of a query or texel, and the series' coordinate y of cos phi under it (cos phi when unwarped).
    double azimuth_tau(double n_dot_v, double n_dot_l) const;
    double azimuth_coordinate(double cos_phi, double n_dot_v, double n_dot_l) const;
    // Node k of K of a texel at (NdotV, NdotL): the azimuth where y = cos(pi k / (K - 1)) (Chebyshev-Lobatto
    // in y; pi k / (K - 1) itself when unwarped), radians.
    double azimuth_node(std::uint32_t k, std::uint32_t nodes, double n_dot_v, double n_dot_l) const;

    // Parameters of texel (iv, il, ivv) (NdotL depends on visibility under the shadow-edge warps, and
    // on the roughness node ir under edge_roughness).
    double visibility_at(std::uint32_t iv, std::uint32_t ir = 0, double n_dot_v = 1) const;
    double n_dot_l_at(std::uint32_t iv, std::uint32_t il, std::uint32_t ir = 0, double n_dot_v = 1) const;
    double n_dot_v_at(std::uint32_t ivv) const;
    // Warped coordinates in [0, 1] of a lookup's parameters (the inverse of the above). n_dot_l_u of a
    // point in the zero region is <= 0 (the lookup returns 0 there before reading any texel).
    double n_dot_l_u(double visibility, double n_dot_l, std::uint32_t ir = 0, double n_dot_v = 1) const;
    double n_dot_v_u(double n_dot_v) const;
    double visibility_u(double visibility) const;  // linear and sqrt-top only
    // The continuous texel coordinate of a warped NdotL or NdotV coordinate u on an n-texel axis,
    // clamped to [0, n - 1] (the placement's inverse: u n - 0.5 at centres, u (n - 1) at the ends).
    double texel_of(double u, std::uint32_t n) const;
    // The visibility cone's cosine c(v) (cosine AO: sqrt(1 - v), uniform: 1 - v), where a smooth
    // surface's shadow edge lies (NdotL = c).
    double edge_cos(double visibility) const;
    // The continuous visibility texel coordinate of a visibility, clamped to [0, n - 1].
    double visibility_texel_of(double visibility, std::uint32_t ir = 0, double n_dot_v = 1) const;
};

// The domain of a grid: its roughness nodes' range, the given visibility and NdotV ranges, any NdotL
// (core/lookup_domain.hpp; a file without a recorded domain answers for this one).
LookupDomain grid_domain(const ReprGrid& grid, double visibility_min = 0, double visibility_max = 1,
                         double n_dot_v_min = 0, double n_dot_v_max = 1);

// The term per texel and azimuth node: nodes phi_k = pi k / (K - 1), k = 0..K-1 (endpoints included).
// value/std_error[index(r, k, iv, il, ivv)]; std_error is the replicate standard error (Student-t,
// replicates - 1 degrees of freedom; exact texels get 0).
struct AzimuthBake {
    ReprGrid grid;
    std::uint32_t azimuth_nodes = 9;
    std::uint32_t replicates = 8;
    std::vector<float> value, std_error;
    nlohmann::json metadata;  // how it was made (samples, seed, sequence, form, seconds, ...)

    double azimuth_at(std::uint32_t k) const;  // radians
    std::size_t index(std::uint32_t r, std::uint32_t k, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const {
        return (((std::size_t(r) * azimuth_nodes + k) * grid.n_dot_v + ivv) * grid.n_dot_l + il) * grid.visibility + iv;
    }
    // A bake of a subset of the roughness nodes (exactly the same texels: no new sampling).
    AzimuthBake with_roughness(const std::vector<std::uint32_t>& roughness_indices) const;
};

struct AzimuthBakeSpec {
    ReprGrid grid;
    std::uint32_t azimuth_nodes = 9;
    SamplingPlan plan;       // samples per texel and node, replicates, seed, sequence
    TermOptions term;        // form; term.ao_weighting must equal grid.weighting
    std::string command_line;
};

class Representation : public approx::Approximation {
public:
    ~Representation() override = default;
    std::string kind() const override = 0;  // "azimuth-axis" | "azimuth-harmonics" | "anisotropic-harmonics" | "anisotropic-mapped-harmonics" | "anisotropic-corrected-harmonics"
    std::string name() const override = 0;  // kind and layout in words
    approx::Cost cost() const override = 0;
    // The renderer's lookup (the generated shader's arithmetic, in double).
    double operator()(const approx::Inputs& in) const override = 0;
    nlohmann::json provenance() const override = 0;

    // The sampling code: a function library ms_micro_shadowing(tex, visibility, NdotL, NdotV,
    // roughness, cos_phi) with cos_phi = the cosine of the relative azimuth.
    virtual std::string shader(ShaderLanguage language, const std::string& source_name) const = 0;
    // The texture as a renderer uploads it: width x height x depth texels of RGBA floats.
    virtual std::uint32_t texture_width() const = 0;
    virtual std::uint32_t texture_height() const = 0;
    virtual std::uint32_t texture_depth() const = 0;
    virtual const std::vector<float>& texels() const = 0;  // RGBA interleaved, x fastest, then y, then z
    // The representation's file as the one texture writer takes it (lut/formats/texture_writer.hpp),
    // 16-bit floats with `half`, else 32-bit: `exr` the atlas (depth slices stacked down the rows, the
    // meaningful channels named), `ktx2` / `dds` the texture alone as an engine loads it (RGBA; texels(),
    // dimensions and x/y/z order as the generated shader samples them: a 3D texture width x height x
    // depth, KTXorientation "rdi"; the metadata in KTX2's key/value data, key "microshadow", or in DDS's
    // `<file>.json`).
    virtual lutfmt::TextureData texture_file(lutfmt::TextureFormat format, bool half) const = 0;
    // Writes the file at `path`, the format by its extension (.exr, .ktx2 or .dds, any case),
    // atomically. std::invalid_argument for another extension; std::runtime_error naming the file on I/O errors.
    void write(const std::string& path, bool half) const;
    virtual const ReprGrid& grid() const = 0;
};

// The anisotropic term (anisotropic.cpp derives it): "anisotropic-harmonics", per texel of (visibility,
// NdotL, NdotV) and per pair of nodes of the projected roughness along V and along L, the least-squares
// series a0 + a1 cos(dphi) + a2 cos(2 dphi) + a3 rho over surfaces of every slope correlation rho and
// relative azimuth dphi with alpha ratio <= max_ratio. Its lookup reads approx::Inputs' alpha_x,
// alpha_y and tangent-relative azimuths (an isotropic caller's roughness and relative azimuth when the
// alphas are unset); its shader's entry point takes V and L in the tangent frame and alpha_x, alpha_y.
// The grid: geometric roughness nodes (both axes; projected alpha = node^2), the edge-roughness NdotL
// warp. No command bakes this kind any more (the anisotropic preset is anisotropic-corrected-harmonics);
// files of it still open, look up and generate their shaders.
// From coefficients already computed (RGBA, x fastest; a bake's texture, or a test's): width
// visibility x nodes, height NdotL, depth NdotV x nodes. metadata's "coefficient_bound" is the channel
// range (the largest |value|, at least 1, when absent).
std::unique_ptr<Representation> build_anisotropic_harmonics(const ReprGrid& grid, std::vector<float> rgba,
                                                            nlohmann::json metadata = nlohmann::json::object());

// Builders from a bake (the bake's roughness nodes: azimuth-axis takes 1 to 4, harmonics 1 or more).
std::unique_ptr<Representation> build_azimuth_axis(const AzimuthBake& bake);
// anisotropic_mapped: "anisotropic-mapped-harmonics", the anisotropic preset's kind: the same texture,
// looked up at an anisotropic surface's isotropic equivalent (harmonics.cpp derives it); its lookup reads
// approx::Inputs' alpha_x, alpha_y and tangent-relative azimuths, its shader's entry point takes V and L in
// the tangent frame and alpha_x, alpha_y (as anisotropic-harmonics').
std::unique_ptr<Representation> build_azimuth_harmonics(const AzimuthBake& bake, bool anisotropic_mapped = false);
// The isotropic equivalent an anisotropic-mapped-harmonics lookup reads its texture at, for a surface
// alpha_x, alpha_y with V and L at azimuths view_azimuth, light_azimuth from the tangent (radians):
// roughness, cos of the relative azimuth, NdotV and NdotL, each the query's own on an isotropic surface.
struct IsotropicEquivalent {
    double roughness, cos_phi, n_dot_v, n_dot_l;
};
IsotropicEquivalent isotropic_equivalent(double alpha_x, double alpha_y, double view_azimuth, double light_azimuth, double n_dot_v,
                                         double n_dot_l);

// "anisotropic-corrected-harmonics", the anisotropic preset's kind (harmonics.cpp derives it): the
// anisotropic-mapped-harmonics lookup plus a correction c . g per texel, c four coefficients in a second
// block of slabs on the same grid (read at the same texel coordinates), g the anisotropy features below;
// 4 fetches. On an isotropic surface g = 0 and the lookup is the azimuth-harmonics one.
// g = (log(alpha_l / alpha_g), log(alpha_v / alpha_g), rho - cos(dphi), log(alpha_rms / alpha_g)):
// projected roughnesses along L and V, their slopes' correlation, alpha_g = sqrt(alpha_x alpha_y),
// alpha_rms = sqrt((alpha_x^2 + alpha_y^2) / 2); azimuths in radians from the tangent.
std::array<double, 4> anisotropy_features(double alpha_x, double alpha_y, double view_azimuth, double light_azimuth);
// Texels of the correction block of a grid (visibility x NdotL x NdotV x roughness nodes).
std::size_t anisotropic_correction_texels(const ReprGrid& grid);
// From a bake of the harmonics and the correction's coefficients (RGBA, x fastest, the same layout as
// the harmonics' texture; empty: zero, the mapped lookup itself); correction_metadata (how it was
// fitted) is recorded as "correction".
std::unique_ptr<Representation> build_anisotropic_corrected(const AzimuthBake& bake, const std::vector<float>& correction,
                                                            const nlohmann::json& correction_metadata);
// The lookup of an anisotropic-corrected-harmonics representation at `in`, written as a linear function
// of its correction: before the final clamp to [0, 1] it is base + sum_k weight[k] dot(c(texel[k]), features),
// texel numbers within the correction block. active is false where the lookup answers by rule (the zero
// region, full visibility) and reads no texel. std::invalid_argument for another kind.
struct CorrectionStencil {
    bool active = false;
    double base = 0;
    std::array<double, 4> features{0, 0, 0, 0};
    std::size_t texels = 0;  // entries used: 8 per roughness slab read
    std::array<std::uint32_t, 16> texel{};
    std::array<double, 16> weight{};
};
CorrectionStencil correction_stencil(const Representation& representation, const approx::Inputs& in);
std::unique_ptr<Representation> build_representation(const std::string& kind, const AzimuthBake& bake);
std::vector<std::string> representation_kinds();

// Reads a representation file written by write(): the OpenEXR, the KTX2 (its metadata from
// the key/value data) or the DDS (its metadata from `<file>.json`). Throws
// std::runtime_error naming the file and problem (for a LUT: the commands that read LUTs).
std::unique_ptr<Representation> open_representation(const std::string& path);
// True when the file is an OpenEXR, KTX2 or DDS whose "microshadow" metadata has "kind": "representation".
bool is_representation_file(const std::string& path);

// Roughness nodes chosen by error: from the bake's roughness nodes (a dense reference, increasing), keep
// `count` (>= 2) including the first and last, minimising the N.L-weighted RMS, over every texel, azimuth
// node and dense node, of the linear blend across roughness between the kept nodes (the error a lookup
// makes at the dense nodes it does not keep). Every subset when C(dense - 2, count - 2) <= 20000, else
// greedy insertion refined by single-node exchanges. Returns indices into bake.grid.roughness,
// increasing, and that RMS in *rms.
std::vector<std::uint32_t> choose_roughness_nodes(const AzimuthBake& bake, std::uint32_t count,
                                                  double* rms = nullptr);

}  // namespace ms::repr
