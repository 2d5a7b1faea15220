#include "scene/inputs.hpp"
#include "io/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

namespace ms::scene {

namespace {

Vec3 sub(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 scale(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
Vec3 add(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double length(Vec3 a) { return std::hypot(a.x, a.y, a.z); }
Vec3 unit(Vec3 a) { return scale(a, 1.0 / length(a)); }

std::string where(const Plane& p, std::size_t i) {
    return p.file + ": channel '" + p.channel + "': pixel (" + std::to_string(i % p.width) + ", " +
           std::to_string(i / p.width) + ")";
}

std::string where3(const std::vector<Plane>& p, std::size_t i) {
    return p[0].file + ": channels '" + p[0].channel + "', '" + p[1].channel + "', '" + p[2].channel + "': pixel (" +
           std::to_string(i % p[0].width) + ", " + std::to_string(i / p[0].width) + ")";
}

}  // namespace

SceneInputs SceneInputs::load(const SceneDescription& d) {
    SceneInputs s;
    s.d_ = d;
    // Each file read once for all the channels asked of it.
    auto read_scalar = [&](const ScalarSource& src) {
        return src.from_image() ? read_channels(src.file, {src.channel}) : std::vector<Plane>{};
    };
    auto read_vector = [&](const VectorSource& src) {
        return src.from_image() ? read_channels(src.file, {src.channels[0], src.channels[1], src.channels[2]})
                                : std::vector<Plane>{};
    };
    s.normal_ = read_vector(d.normal.source);
    s.visibility_ = read_scalar(d.visibility);
    s.roughness_ = read_scalar(d.roughness);
    s.anisotropy_ = read_scalar(d.anisotropy);
    if (d.has_tangent) s.tangent_ = read_vector(d.tangent);
    if (d.mask.present) s.mask_ = read_scalar(d.mask.source);
    if (d.has_material) s.material_ = read_scalar(d.material);
    if (d.view.kind == ViewKind::vectors) s.view_ = read_vector(d.view.vectors);
    if (d.view.kind == ViewKind::position) s.position_ = read_vector(d.view.position);

    for (const auto* group : {&s.normal_, &s.visibility_, &s.roughness_, &s.anisotropy_, &s.tangent_, &s.mask_,
                              &s.material_, &s.view_, &s.position_})
        for (const Plane& p : *group) {
            if (s.size_source_.empty()) {
                s.width_ = p.width;
                s.height_ = p.height;
                s.x0_ = p.x0;
                s.y0_ = p.y0;
                s.size_source_ = p.file + " (channel '" + p.channel + "')";
            } else if (p.width != s.width_ || p.height != s.height_) {
                throw SceneError(p.file + ": channel '" + p.channel + "' is " + std::to_string(p.width) + " x " +
                                 std::to_string(p.height) + " pixels; the scene is " + std::to_string(s.width_) + " x " +
                                 std::to_string(s.height_) + " (set by " + s.size_source_ + ")");
            } else if (p.x0 != s.x0_ || p.y0 != s.y0_) {
                // Same size, other pixels: EXR parts (or files) whose data windows start elsewhere would be
                // combined pixel by index, misaligned.
                throw SceneError(p.file + ": channel '" + p.channel + "' has its data window at (" + std::to_string(p.x0) + ", " +
                                 std::to_string(p.y0) + "); the scene's starts at (" + std::to_string(s.x0_) + ", " +
                                 std::to_string(s.y0_) + ") (set by " + s.size_source_ +
                                 "): every input must cover the same pixels (write the passes with one data window)");
            }
        }
    if (s.size_source_.empty())
        throw SceneError(d.source + ": no input comes from an image, so the scene has no size (give at least one file)");

    // Constants checked once, with the key that holds them.
    auto check_constant = [&](bool image, double v, double lo, double hi, const std::string& key) {
        if (!image && !(v >= lo && v <= hi))
            throw SceneError(d.source + ": " + key + ": " + format_g(v, 9) + " outside [" + format_g(lo, 9) + ", " + format_g(hi, 9) + "]");
    };
    check_constant(d.visibility.from_image(), d.visibility.value, 0, 1, "visibility.value");
    check_constant(d.roughness.from_image(), d.roughness.value, d.roughness_kind == RoughnessKind::alpha ? 1e-300 : 0, 1,
                   "roughness.value");
    check_constant(d.anisotropy.from_image(), d.anisotropy.value, -1, 1, "anisotropy.value");

    // Every shaded pixel checked before any work: the first problem is reported, with its pixel.
    auto finite = [](const std::vector<Plane>& planes, std::size_t i) {
        for (const Plane& p : planes)
            if (!std::isfinite(p.data[i])) return &p;
        return static_cast<const Plane*>(nullptr);
    };
    std::set<int> materials;
    for (std::size_t i = 0; i < s.pixels(); ++i) {
        if (!s.mask_.empty() && std::isnan(s.mask_[0].data[i]))  // infinity is a legal background (depth)
            throw SceneError(where(s.mask_[0], i) + ": NaN in the mask");
        if (!s.in_mask(i)) continue;
        for (const auto* group : {&s.normal_, &s.visibility_, &s.roughness_, &s.anisotropy_, &s.tangent_, &s.material_,
                                  &s.view_, &s.position_})
            if (const Plane* bad = finite(*group, i))
                throw SceneError(where(*bad, i) + ": " + format_g(bad->data[i], 9) + " is not a finite number");
        if (!s.normal_.empty() && !(length(s.world_normal(i)) > 1e-6))
            throw SceneError(where3(s.normal_, i) + ": zero-length normal");
        if (!s.visibility_.empty()) {
            const float v = s.visibility_[0].data[i];
            if (!(v >= 0 && v <= 1)) throw SceneError(where(s.visibility_[0], i) + ": visibility " + format_g(v, 9) + " outside [0, 1]");
        }
        if (!s.roughness_.empty()) {
            const float r = s.roughness_[0].data[i];
            if (!(r >= 0 && r <= 1)) throw SceneError(where(s.roughness_[0], i) + ": roughness " + format_g(r, 9) + " outside [0, 1]");
        }
        if (!s.anisotropy_.empty()) {
            const float a = s.anisotropy_[0].data[i];
            if (!(a >= -1 && a <= 1)) throw SceneError(where(s.anisotropy_[0], i) + ": anisotropy " + format_g(a, 9) + " outside [-1, 1]");
        }
        const PixelSurface p = s.pixel(i);
        if (p.alpha_x != p.alpha_y && !p.anisotropic)
            throw SceneError((s.tangent_.empty() ? d.source + ": tangent.value" : where3(s.tangent_, i)) +
                             ": the tangent is zero or parallel to the normal at an anisotropic pixel (" +
                             std::to_string(i % s.width_) + ", " + std::to_string(i / s.width_) + ")");
        if (!s.view_.empty() && !(length({double(s.view_[0].data[i]), double(s.view_[1].data[i]), double(s.view_[2].data[i])}) > 1e-12))
            throw SceneError(where3(s.view_, i) + ": zero-length view vector");
        if (!s.position_.empty() && !(length(sub(d.view.camera, p.position)) > 0))
            throw SceneError(where3(s.position_, i) + ": the position is the camera's");
        if (!s.material_.empty()) {
            // Material indices are stored integers (EXR: floats holding them); beyond 2^24 a float no longer
            // holds every integer, and an int would wrap.
            const double m = double(s.material_[0].data[i]) * s.material_[0].integer_scale;
            if (!(std::fabs(m) <= kMaxMaterialIndex))
                throw SceneError(where(s.material_[0], i) + ": material index " + format_g(m, 9) + " outside [-" + format_g(kMaxMaterialIndex, 9) +
                                 ", " + format_g(kMaxMaterialIndex, 9) + "]");
            if (materials.insert(int(std::lround(m))).second && materials.size() > kMaxMaterials)
                throw SceneError(where(s.material_[0], i) + ": more than " + std::to_string(kMaxMaterials) +
                                 " distinct material indices (each is a statistics group of the report)");
        }
        // Every light's irradiance here must be a finite number whose square sums stay finite: a point
        // light 1e-170 above a pixel gives I / d^2 = inf.
        for (std::size_t l = 0; l < d.lights.size(); ++l) {
            if (d.lights[l].type == LightType::sphere && !(length(sub(d.lights[l].position, p.position)) > d.lights[l].radius))
                throw SceneError(d.source + ": light[" + std::to_string(l) + "] '" + d.lights[l].name + "': pixel (" +
                                 std::to_string(i % s.width_) + ", " + std::to_string(i / s.width_) +
                                 ") is inside the sphere light (distance to its centre " +
                                 format_g(length(sub(d.lights[l].position, p.position)), 9) + " <= radius " + format_g(d.lights[l].radius, 9) + ")");
            if (d.lights[l].is_area()) continue;  // radiance: the weight is bounded by intensity x pi
            const LightQuery q = light_query(p, d.lights[l]);
            if (!(q.irradiance <= kMaxIrradiance))
                throw SceneError(d.source + ": light[" + std::to_string(l) + "] '" + d.lights[l].name + "': irradiance " +
                                 format_g(q.irradiance, 9) + " at pixel (" + std::to_string(i % s.width_) + ", " +
                                 std::to_string(i / s.width_) + ") is beyond " + format_g(kMaxIrradiance, 9) +
                                 " (a point light on or next to the surface, or too bright)");
        }
    }
    return s;
}

bool SceneInputs::in_mask(std::size_t i) const {
    if (mask_.empty()) return true;
    const double m = mask_[0].data[i];
    switch (d_.mask.kind) {
        case MaskKind::alpha: return m >= d_.mask.threshold;
        case MaskKind::background: return m != d_.mask.background;
        case MaskKind::object_index: {
            const long id = std::lround(m * mask_[0].integer_scale);
            if (d_.mask.objects.empty()) return id != 0;
            return std::find(d_.mask.objects.begin(), d_.mask.objects.end(), id) != d_.mask.objects.end();
        }
    }
    return true;
}

Vec3 SceneInputs::world_normal(std::size_t i) const {
    Vec3 n = d_.normal.source.value;
    if (!normal_.empty()) {
        n = {double(normal_[0].data[i]), double(normal_[1].data[i]), double(normal_[2].data[i])};
        if (d_.normal.encoding == VectorEncoding::unorm) n = {2 * n.x - 1, 2 * n.y - 1, 2 * n.z - 1};
    }
    if (d_.normal.space == NormalSpace::tangent) {
        if (d_.normal.green_down) n.y = -n.y;
        const Vec3 N = unit(d_.surface.normal);
        const Vec3 T = unit(sub(d_.surface.tangent, scale(N, dot(d_.surface.tangent, N))));
        const Vec3 B = cross(N, T);
        n = add(add(scale(T, n.x), scale(B, n.y)), scale(N, n.z));
    }
    return n;
}

PixelSurface SceneInputs::pixel(std::size_t i) const {
    PixelSurface p;
    p.shaded = in_mask(i);
    if (!p.shaded) return p;
    const Vec3 n = world_normal(i);
    p.normal = length(n) > 0 ? unit(n) : Vec3{0, 0, 1};
    // World position: the position pass, or the plane of the texture set.
    if (!position_.empty()) {
        p.position = {double(position_[0].data[i]), double(position_[1].data[i]), double(position_[2].data[i])};
    } else {
        const Vec3 N = unit(d_.surface.normal);
        const Vec3 T = unit(sub(d_.surface.tangent, scale(N, dot(d_.surface.tangent, N))));
        const Vec3 B = cross(N, T);
        const double u = (double(i % width_) + 0.5) / width_, v = (double(i / width_) + 0.5) / height_;
        p.position = add(d_.surface.origin, add(scale(T, u * d_.surface.width), scale(B, (1 - v) * d_.surface.height)));
    }
    switch (d_.view.kind) {
        case ViewKind::direction: p.view = unit(d_.view.direction); break;
        case ViewKind::vectors: {
            Vec3 v{double(view_[0].data[i]), double(view_[1].data[i]), double(view_[2].data[i])};
            if (d_.view.encoding == VectorEncoding::unorm) v = {2 * v.x - 1, 2 * v.y - 1, 2 * v.z - 1};
            p.view = length(v) > 0 ? unit(v) : Vec3{0, 0, 1};
            break;
        }
        case ViewKind::position: {
            const Vec3 v = sub(d_.view.camera, p.position);
            p.view = length(v) > 0 ? unit(v) : Vec3{0, 0, 1};
            break;
        }
    }
    p.visibility = scalar(visibility_, d_.visibility, i);
    const double r = scalar(roughness_, d_.roughness, i);
    const double alpha = d_.roughness_kind == RoughnessKind::perceptual ? r * r : r;
    const double a = scalar(anisotropy_, d_.anisotropy, i);
    p.alpha_x = std::max(kMinAlpha, alpha * (1 + a));
    p.alpha_y = std::max(kMinAlpha, alpha * (1 - a));
    p.roughness = std::pow(p.alpha_x * p.alpha_y, 0.25);
    if (d_.has_tangent) {
        Vec3 t = d_.tangent.value;
        if (!tangent_.empty()) {
            t = {double(tangent_[0].data[i]), double(tangent_[1].data[i]), double(tangent_[2].data[i])};
            if (d_.tangent_encoding == VectorEncoding::unorm) t = {2 * t.x - 1, 2 * t.y - 1, 2 * t.z - 1};
        }
        const Vec3 tp = sub(t, scale(p.normal, dot(t, p.normal)));
        if (length(tp) > 1e-9 * std::max(1.0, length(t))) {
            p.tangent = unit(tp);
            p.anisotropic = p.alpha_x != p.alpha_y;
        }
    }
    if (!material_.empty()) p.material = int(std::lround(material_[0].data[i] * material_[0].integer_scale));
    return p;
}

LightQuery light_query(const PixelSurface& p, const Light& light) {
    LightQuery q;
    if (!p.shaded) return q;
    Vec3 L;
    double intensity = light.intensity;
    if (light.is_area()) {
        // The point query towards the centre; its irradiance means nothing for a light of given radiance
        // (the area weight is computed with T_area), so it is 0, never a huge I / d^2 of a near centre.
        Light centre = light;
        centre.type = LightType::point;
        centre.position = area_light_centre(light);
        LightQuery q = light_query(p, centre);
        q.irradiance = 0;
        return q;
    }
    if (light.type == LightType::directional) {
        L = unit(light.direction);
    } else {
        const Vec3 d = sub(light.position, p.position);
        const double dist = length(d);
        if (!(dist > 0)) {
            q.status = PixelStatus::light_below_horizon;
            return q;
        }
        L = {d.x / dist, d.y / dist, d.z / dist};  // not scale(d, 1 / dist): 1 / dist overflows for dist < 1e-308
        intensity = intensity / dist / dist;       // inf where d^2 would underflow to 0; SceneInputs::load refuses it
    }
    const Vec3 n = p.normal;
    q.n_dot_v = dot(n, p.view);
    q.n_dot_l = dot(n, L);
    q.irradiance = std::max(0.0, q.n_dot_l) * intensity;
    if (!(q.n_dot_v > 1e-6)) {
        q.status = PixelStatus::view_below_horizon;
        return q;
    }
    q.status = q.n_dot_l > 0 ? PixelStatus::shaded : PixelStatus::light_below_horizon;
    const double cv = std::min(1.0, q.n_dot_v), cl = std::clamp(q.n_dot_l, -1.0, 1.0);
    const double sv = std::sqrt(std::max(0.0, 1 - cv * cv)), sl = std::sqrt(std::max(0.0, 1 - cl * cl));
    q.query.visibility = p.visibility;
    q.query.alpha_x = p.alpha_x;
    q.query.alpha_y = p.alpha_y;
    if (p.anisotropic) {
        const Vec3 x = p.tangent, y = cross(n, x);
        q.query.wi = {dot(p.view, x), dot(p.view, y), cv};
        q.query.wo = {dot(L, x), dot(L, y), cl};
        return q;
    }
    // Isotropic: x along V's projection (or L's, when V is the normal); phi = relative azimuth in [0, pi].
    const Vec3 vp = sub(p.view, scale(n, dot(p.view, n))), lp = sub(L, scale(n, dot(L, n)));
    const double lv = length(vp), ll = length(lp);
    double cos_phi = 1;
    if (lv > 1e-12 && ll > 1e-12) cos_phi = std::clamp(dot(vp, lp) / (lv * ll), -1.0, 1.0);
    q.azimuth = std::acos(cos_phi);
    const double sin_phi = std::sin(q.azimuth);
    q.query.wi = {sv, 0, cv};
    q.query.wo = {sl * cos_phi, sl * sin_phi, cl};
    return q;
}

Vec3 area_light_centre(const Light& light) {
    if (light.type == LightType::sphere) return light.position;
    const auto& k = light.corners;
    return {0.5 * (k[0].x + k[2].x), 0.5 * (k[0].y + k[2].y), 0.5 * (k[0].z + k[2].z)};
}

AreaLightQuery area_light_query(const PixelSurface& p, const Light& light) {
    AreaLightQuery a;
    a.centre = light_query(p, light);
    a.status = a.centre.status;
    if (a.status == PixelStatus::masked || a.status == PixelStatus::view_below_horizon) return a;
    const Vec3 n = p.normal;
    const Vec3 centre = sub(area_light_centre(light), p.position);
    // The frame of light_query: the tangent; else V's projection; else the centre's; else any.
    Vec3 x;
    if (p.anisotropic) {
        x = p.tangent;
    } else {
        Vec3 vp = sub(p.view, scale(n, dot(p.view, n)));
        if (!(length(vp) > 1e-12)) vp = sub(centre, scale(n, dot(centre, n)));
        if (!(length(vp) > 1e-12 * length(centre))) vp = std::fabs(n.x) < 0.9 ? cross(n, Vec3{1, 0, 0}) : cross(n, Vec3{0, 1, 0});
        x = scale(vp, 1.0 / length(vp));
    }
    const Vec3 y = cross(n, x);
    auto local = [&](const Vec3& w) { return Vec3{dot(w, x), dot(w, y), dot(w, n)}; };
    area::AreaQuery& q = a.query;
    q.visibility = p.visibility;
    q.alpha_x = p.alpha_x;
    q.alpha_y = p.alpha_y;
    q.wi = local(p.view);
    q.wi.z = std::min(1.0, a.centre.n_dot_v);
    q.lobe = light.lobe;
    if (light.type == LightType::sphere) {
        const double d = length(centre);
        q.light.shape = area::LightShape::sphere;
        q.light.sphere.centre = local(centre);
        // Inside (or on) the sphere is refused by load(); a half-angle that rounds to 90 degrees too.
        if (!(d > light.radius) || !(light.radius / d < 1 - 1e-12)) {
            a.status = PixelStatus::light_below_horizon;
            return a;
        }
        q.light.sphere.half_angle = std::asin(light.radius / d);
    } else {
        q.light.shape = area::LightShape::rect;
        for (int k = 0; k < 4; ++k) q.light.rect.corners[k] = local(sub(light.corners[k], p.position));
    }
    try {
        area::validate(q);
    } catch (const std::invalid_argument&) {
        // The shape was checked when the description was read; what is left is the pixel in the
        // rectangle's plane (no solid angle): no light.
        a.status = PixelStatus::light_below_horizon;
        return a;
    }
    a.status = PixelStatus::shaded;  // the light may still lie below the horizon (the caller classifies it)
    return a;
}

}  // namespace ms::scene
