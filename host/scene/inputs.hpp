// A scene's per-pixel inputs, read and checked, and the tangent-frame query of a pixel under a light.
//
// The query frame (normal = +z) of a pixel:
//   - anisotropic roughness (a tangent input is given): x = the tangent projected on the shading
//     normal's plane (Gram-Schmidt), y = z x x; wi and wo are V and L in that frame;
//   - isotropic roughness: the frame's azimuth is free, because nothing in the term depends on it. The
//     GGX distribution, Smith's Lambda (alpha_w = alpha for every azimuth), the visible-normal
//     distribution and both cone tests (dot products with wg = +z and with wo) are unchanged when wi,
//     wo and every microfacet normal are rotated together about +z, so the term of (wi, wo) equals
//     that of the rotated pair; and a mirror y -> -y maps the distribution onto itself. So the term is
//     a function of NdotV, NdotL and the relative azimuth |phi_l - phi_v| in [0, pi] alone. The frame
//     is chosen with x along V's projection: wi = (sin_v, 0, cos_v), wo = (sin_l cos phi,
//     sin_l sin phi, cos_l) with phi in [0, pi]: a canonical query, the same for every pixel that
//     shares those four numbers and alpha (which is what makes deduplication possible).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "scene/description.hpp"
#include "scene/image_io.hpp"

namespace ms::scene {

// Smallest alpha a pixel is evaluated at (roughness 0 maps here: the term is then part 1's step).
inline constexpr double kMinAlpha = 1e-3;
// Material indices: |index| <= 2^24 (every such integer is a float), at most kMaxMaterials distinct.
inline constexpr double kMaxMaterialIndex = 16777216;
inline constexpr std::size_t kMaxMaterials = 65536;
// Largest irradiance a pixel may receive from a light (its weighted errors are squared and summed).
inline constexpr double kMaxIrradiance = 1e100;

struct PixelSurface {
    bool shaded = false;  // inside the mask
    Vec3 normal;          // world-space shading normal, unit
    Vec3 tangent;         // unit, perpendicular to normal (anisotropic pixels)
    bool anisotropic = false;
    Vec3 view;            // unit, towards the viewer
    Vec3 position;        // world position (point lights)
    double visibility = 1, alpha_x = 0.25, alpha_y = 0.25;
    double roughness = 0.5;  // perceptual, (alpha_x alpha_y)^(1/4): the LUT's roughness axis
    int material = 0;
};

enum class PixelStatus { shaded, masked, view_below_horizon, light_below_horizon };

struct LightQuery {
    PixelStatus status = PixelStatus::masked;
    double n_dot_v = 0, n_dot_l = 0;
    double azimuth = 0;     // relative azimuth in [0, pi] (isotropic pixels)
    double irradiance = 0;  // max(NdotL, 0) x the light's intensity (point lights: / distance^2)
    Query query;            // the tangent-frame query (valid when status is shaded)
};

class SceneInputs {
public:
    // Reads every image the description names and checks every shaded pixel. Throws SceneError naming
    // the file, the channel and the pixel (NaN or infinite values, zero-length normals or vectors,
    // visibility outside [0, 1], roughness outside [0, 1] (alpha: (0, 1]), anisotropy outside [-1, 1],
    // images of different sizes or data windows, a missing channel, material indices beyond
    // kMaxMaterialIndex or more than kMaxMaterials of them, a light whose irradiance at a pixel is
    // beyond kMaxIrradiance).
    static SceneInputs load(const SceneDescription& description);

    std::uint32_t width() const { return width_; }
    std::uint32_t height() const { return height_; }
    std::size_t pixels() const { return std::size_t(width_) * height_; }
    PixelSurface pixel(std::size_t index) const;
    const SceneDescription& description() const { return d_; }

private:
    SceneDescription d_;
    std::uint32_t width_ = 0, height_ = 0;
    int x0_ = 0, y0_ = 0;  // the data window's corner every plane shares
    std::string size_source_;
    // Planes by role (empty: constant).
    std::vector<Plane> normal_, visibility_, roughness_, anisotropy_, tangent_, mask_, material_, view_, position_;
    Vec3 world_normal(std::size_t i) const;
    double scalar(const std::vector<Plane>& planes, const ScalarSource& s, std::size_t i) const {
        return planes.empty() ? s.value : double(planes[0].data[i]);
    }
    bool in_mask(std::size_t i) const;
};

// The query of a pixel under a light (see the frame above). Area lights: the point query towards the
// light's centre (what engines look up in its place), with irradiance 0 (their weight is not I / d^2).
LightQuery light_query(const PixelSurface& pixel, const Light& light);

// The query of a pixel under an area light (sphere or rect), in the frame above (isotropic pixels: x
// along V's projection, or the centre's when V is the normal): the light's positions relative to the
// pixel, in that frame. status light_below_horizon: the pixel in a rectangle's plane (edge-on: no solid
// angle), the term 0 and so is the weight; shaded: a light to integrate, which may still lie wholly below
// the horizon (integrands/area_light/light_geometry.hpp, max_height, tells). A pixel inside a sphere light
// is refused by SceneInputs::load.
struct AreaLightQuery {
    PixelStatus status = PixelStatus::masked;
    area::AreaQuery query;  // valid when status is shaded
    LightQuery centre;      // light_query towards the centre
};
AreaLightQuery area_light_query(const PixelSurface& pixel, const Light& light);
// The world position of an area light's centre (a rectangle's centre of area).
Vec3 area_light_centre(const Light& light);

}  // namespace ms::scene
