// The scene description (TOML): which image files and channels hold a scene's per-pixel inputs, how
// to read them, the view, the lights, and how the run samples and compares. The format, with every
// key, is in docs/scenes.md; unknown keys are errors that name the key.
//
// Every per-pixel input is either read from an image ("file" + "channel" / "channels") or a constant
// ("value"); at least one input must come from an image (it sets the scene's size). Paths are
// relative to the description's folder (a symlinked description: its target's folder). Directions are
// stored normalised.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/area_light.hpp"
#include "core/types.hpp"

namespace ms::scene {

// Limits of a description (each refused with the key that breaks it).
inline constexpr std::size_t kMaxLights = 64;
inline constexpr double kMaxCoordinate = 1e30;   // positions, camera, surface origin and size
inline constexpr double kMaxIntensity = 1e30;
inline constexpr double kMaxDedupStep = 0.25;    // sampling.dedup_step (docs/scenes.md: the measured shift of the key grid)

struct ScalarSource {
    std::string file, channel;  // file empty: constant
    double value = 0;
    bool from_image() const { return !file.empty(); }
};

struct VectorSource {
    std::string file;
    std::array<std::string, 3> channels;
    Vec3 value;
    bool from_image() const { return !file.empty(); }
};

enum class NormalSpace { world, tangent };
// How stored numbers map to a component: unorm n = 2 c - 1 (PNG normal maps), signed n = c (EXR passes).
enum class VectorEncoding { unorm, signed_ };
enum class RoughnessKind { perceptual, alpha };
enum class MaskKind { alpha, background, object_index };
enum class ViewKind { direction, vectors, position };
enum class LightType { directional, point, sphere, rect };

struct NormalInput {
    VectorSource source;
    NormalSpace space = NormalSpace::world;
    bool green_down = false;  // tangent space: "-Y" (DirectX) green; "+Y" (OpenGL) is the default
    VectorEncoding encoding = VectorEncoding::signed_;
};

struct MaskInput {
    bool present = false;
    ScalarSource source;
    MaskKind kind = MaskKind::alpha;
    double threshold = 0.5;           // alpha: shaded where value >= threshold
    double background = 0;            // background: shaded where value != background
    std::vector<long> objects;        // object_index: shaded where round(value) is listed (empty: != 0)
};

struct ViewInput {
    ViewKind kind = ViewKind::direction;
    Vec3 direction{0, 0, 1};          // direction: towards the viewer, world space
    VectorSource vectors;             // vectors: per pixel, towards the viewer
    VectorEncoding encoding = VectorEncoding::signed_;
    VectorSource position;            // position: world-space position pass ...
    Vec3 camera;                      // ... and the camera position
};

// The plane a texture set lies on: the frame of tangent-space normal maps (tangent T, bitangent
// B = N x T, normal N), and world positions for point lights when there is no position pass:
// pixel (x, y) sits at origin + u width T + (1 - v) height B, u = (x + 0.5) / W, v = (y + 0.5) / H
// (image rows go down, +B goes up, as a +Y normal map's green does).
struct Surface {
    Vec3 normal{0, 0, 1}, tangent{1, 0, 0}, origin{0, 0, 0};
    double width = 1, height = 1;
};

// Area lights (sphere, rect) are micro-shadowed over their extent (core/area_light.hpp): the pixel's
// reference is T_area, weighted by the BRDF lobe `lobe`, and their `intensity` is the emitter's
// radiance, so a pixel's unshadowed contribution is intensity x Int_light f cos dw (f the lobe).
struct Light {
    std::string name;
    LightType type = LightType::directional;
    Vec3 direction{0, 0, 1};  // directional: towards the light
    Vec3 position;            // point; sphere: the centre
    double radius = 0;        // sphere
    std::array<Vec3, 4> corners{};  // rect: world positions in order around the rectangle
    area::Lobe lobe = area::Lobe::lambert;  // area lights: the BRDF lobe the light is weighted by
    double intensity = 1;     // directional: irradiance at normal incidence; point: intensity (irradiance I / d^2); area: radiance
    bool is_area() const { return type == LightType::sphere || type == LightType::rect; }
};

struct Comparators {
    std::vector<std::string> analytic;  // part 1's terms by name (empty list: none); default: all
    bool seed_3d = true, seed_2d = true;
    std::uint32_t lut_size = 32;
    std::uint64_t lut_samples = 16384;
    std::vector<std::string> luts;      // LUT files (paths resolved)
};

struct SamplingSettings {
    // exact (default): every distinct pixel query by the exact evaluator to `tolerance` (its estimated
    // error; default 1e-6); sampled: VNDF sampling until the 99.9 % bound <= tolerance (default 2e-3).
    // At these defaults the exact reference is both faster and 2000x tighter (docs/exact-method.md).
    Method method = Method::exact;
    bool tolerance_given = false;       // sampling.tolerance in the file (else the method's default)
    double tolerance = 2e-3;            // per-pixel error bound (99.9 %, Student t of the replicates)
    // Area lights (sphere, rect): the per-pixel bound of T_area, t x the outer sampling's std error plus
    // the exact inner term's error bound (both methods sample the light; `tolerance` is then the exact
    // inner term's).
    double area_tolerance = 5e-3;
    std::uint64_t min_samples = 16384;  // first pass, all replicates
    std::uint64_t max_samples = 1 << 20;
    std::uint64_t seed = 0;
    std::uint32_t replicates = 16;      // 8, 16, 32 or 64: the Student t factor of the bound shrinks with more
    Form form = Form::height_correlated;
    double dedup_step = 0.125;          // the key grid step, as a fraction of tolerance x alpha (scene.hpp)
    std::uint32_t predict_stride = 8;   // > 1: queries start at their neighbours' final sample count (scene.cpp); 1: off
    std::uint64_t tile_pixels = 65536;  // pixels classified, deduplicated and sampled at a time (0: all at once; scene.hpp)
};

// The per-pixel tolerance a scene run uses with `method` when none is given.
inline double default_scene_tolerance(Method method) { return method == Method::exact ? 1e-6 : 2e-3; }

struct SceneDescription {
    std::string source;     // the description's path (messages)
    std::string base_dir;
    std::string name = "scene";
    NormalInput normal;
    ScalarSource visibility;
    AoWeighting ao_weighting = AoWeighting::cosine;
    ScalarSource roughness;
    RoughnessKind roughness_kind = RoughnessKind::perceptual;
    ScalarSource anisotropy;            // default constant 0; alpha_x = alpha (1 + a), alpha_y = alpha (1 - a)
    bool has_tangent = false;
    VectorSource tangent;               // world-space tangent direction (anisotropic surfaces)
    VectorEncoding tangent_encoding = VectorEncoding::signed_;
    MaskInput mask;
    ScalarSource material;              // optional material index per pixel (statistics per material)
    bool has_material = false;
    std::vector<std::string> material_names;
    ViewInput view;
    Surface surface;
    std::vector<Light> lights;
    Comparators comparators;
    SamplingSettings sampling;
};

// Parses a description. Throws SceneError ("FILE: key: problem", or "FILE:LINE:COLUMN: TOML syntax").
SceneDescription parse_scene(const std::string& text, const std::string& source_name, const std::string& base_dir);
// Reads the file (io/input_file.hpp's checks) and parses it; paths resolve against its folder.
SceneDescription load_scene(const std::string& path);

std::string to_string(NormalSpace);
std::string to_string(MaskKind);
std::string to_string(ViewKind);
std::string to_string(LightType);

}  // namespace ms::scene
