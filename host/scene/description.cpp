#include "scene/description.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <sstream>

#include "analytic/part1_terms.hpp"
#include "io/csv.hpp"
#include "io/input_file.hpp"
#include "scene/image_io.hpp"

namespace ms::scene {

namespace fs = std::filesystem;

namespace {

struct Ctx {
    std::string source, base_dir;
    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        throw SceneError(source + ": " + key + ": " + what);
    }
    std::string path(const std::string& p) const {
        if (p.empty() || fs::path(p).is_absolute() || base_dir.empty()) return p;
        return (fs::path(base_dir) / p).lexically_normal().string();
    }
};

void reject_unknown(const Ctx& c, const toml::table& t, const std::string& prefix, const std::set<std::string>& known) {
    for (const auto& [k, v] : t) {
        const std::string key(k.str());
        if (!known.count(key)) {
            std::string list;
            for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
            c.fail(prefix + key, "unknown key (known here: " + list + ")");
        }
    }
}

const toml::table* table_at(const Ctx& c, const toml::table& root, const std::string& key) {
    const toml::node* n = root.get(key);
    if (!n) return nullptr;
    if (!n->is_table()) c.fail(key, "must be a table ([" + key + "])");
    return n->as_table();
}

double number(const Ctx& c, const toml::node& n, const std::string& key) {
    if (n.is_integer()) return double(n.as_integer()->get());
    if (n.is_floating_point() && std::isfinite(n.as_floating_point()->get())) return n.as_floating_point()->get();
    c.fail(key, "must be a finite number");
}

std::uint64_t positive(const Ctx& c, const toml::node& n, const std::string& key, std::uint64_t max) {
    if (!n.is_integer() || n.as_integer()->get() <= 0 || std::uint64_t(n.as_integer()->get()) > max)
        c.fail(key, "must be an integer in 1 .. " + std::to_string(max));
    return std::uint64_t(n.as_integer()->get());
}

std::string string(const Ctx& c, const toml::node& n, const std::string& key) {
    if (!n.is_string()) c.fail(key, "must be a string");
    return n.as_string()->get();
}

bool boolean(const Ctx& c, const toml::node& n, const std::string& key) {
    if (!n.is_boolean()) c.fail(key, "must be true or false");
    return n.as_boolean()->get();
}

std::vector<std::string> strings(const Ctx& c, const toml::node& n, const std::string& key) {
    if (!n.is_array()) c.fail(key, "must be a list of strings");
    std::vector<std::string> out;
    for (const auto& e : *n.as_array()) out.push_back(string(c, e, key));
    return out;
}

// A direction (nonzero: normalised here) or a position (bounded by kMaxCoordinate).
Vec3 vec3(const Ctx& c, const toml::node& n, const std::string& key, bool nonzero = true) {
    if (!n.is_array() || n.as_array()->size() != 3) c.fail(key, "must be a list of 3 numbers");
    const auto& a = *n.as_array();
    Vec3 v{number(c, a[0], key), number(c, a[1], key), number(c, a[2], key)};
    if (!nonzero) {
        if (std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}) > kMaxCoordinate)
            c.fail(key, "coordinates must be within +-1e30");
        return v;
    }
    // Scaled by a power of two first, so that neither 1e-320 (subnormal: 1 / length overflows) nor
    // 1.7e308 (the length overflows) loses the direction; the scaling is exact.
    const double largest = std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)});
    if (largest == 0) c.fail(key, "must not be the zero vector");
    int exponent = 0;
    std::frexp(largest, &exponent);
    v = {std::ldexp(v.x, -exponent), std::ldexp(v.y, -exponent), std::ldexp(v.z, -exponent)};
    const double length = std::hypot(v.x, v.y, v.z);
    return {v.x / length, v.y / length, v.z / length};
}

template <class T>
T choice(const Ctx& c, const toml::node& n, const std::string& key, const std::vector<std::pair<std::string, T>>& options) {
    const std::string s = string(c, n, key);
    std::string list;
    for (const auto& [name, value] : options) {
        if (name == s) return value;
        list += (list.empty() ? "" : ", ") + name;
    }
    c.fail(key, "'" + s + "' is not one of " + list);
}

bool png_name(const std::string& f) {
    return f.size() >= 4 && (f.substr(f.size() - 4) == ".png" || f.substr(f.size() - 4) == ".PNG");
}

// file + channel, or value. The keys of `t` other than these are checked by the caller.
ScalarSource scalar(const Ctx& c, const toml::table& t, const std::string& prefix, double default_value, bool required) {
    ScalarSource s;
    s.value = default_value;
    const toml::node* file = t.get("file");
    const toml::node* value = t.get("value");
    if (file && value) c.fail(prefix + "value", "give either file (+ channel) or value, not both");
    if (file) {
        s.file = c.path(string(c, *file, prefix + "file"));
        const toml::node* ch = t.get("channel");
        if (ch) s.channel = string(c, *ch, prefix + "channel");
        else if (png_name(s.file)) s.channel = "R";
        else c.fail(prefix + "channel", "required for a file that is not a PNG (the channel's name in the file)");
    } else if (value) {
        s.value = number(c, *value, prefix + "value");
        if (t.get("channel")) c.fail(prefix + "channel", "given without a file");
    } else if (required) {
        c.fail(prefix + "file", "missing: give file (+ channel) or value");
    }
    return s;
}

VectorSource vector(const Ctx& c, const toml::table& t, const std::string& prefix, const std::string& file_key,
                    const std::string& channels_key, const std::string& value_key, bool required) {
    VectorSource s;
    const toml::node* file = t.get(file_key);
    const toml::node* value = value_key.empty() ? nullptr : t.get(value_key);
    if (file && value) c.fail(prefix + value_key, "give either " + file_key + " (+ " + channels_key + ") or " + value_key + ", not both");
    if (file) {
        s.file = c.path(string(c, *file, prefix + file_key));
        if (const toml::node* ch = t.get(channels_key)) {
            const auto list = strings(c, *ch, prefix + channels_key);
            if (list.size() != 3) c.fail(prefix + channels_key, "must name 3 channels (x, y, z)");
            s.channels = {list[0], list[1], list[2]};
        } else if (png_name(s.file)) {
            s.channels = {"R", "G", "B"};
        } else {
            c.fail(prefix + channels_key, "required for a file that is not a PNG (3 channel names: x, y, z)");
        }
    } else if (value) {
        s.value = vec3(c, *value, prefix + value_key);
        if (t.get(channels_key)) c.fail(prefix + channels_key, "given without a file");
    } else if (required) {
        c.fail(prefix + file_key, "missing: give " + file_key + " (+ " + channels_key + ")" +
                                      (value_key.empty() ? "" : " or " + value_key));
    }
    return s;
}

VectorEncoding encoding(const Ctx& c, const toml::table& t, const std::string& prefix, const VectorSource& s) {
    if (const toml::node* n = t.get("encoding"))
        return choice<VectorEncoding>(c, *n, prefix + "encoding", {{"unorm", VectorEncoding::unorm}, {"signed", VectorEncoding::signed_}});
    return png_name(s.file) ? VectorEncoding::unorm : VectorEncoding::signed_;
}

}  // namespace

std::string to_string(NormalSpace s) { return s == NormalSpace::world ? "world" : "tangent"; }
std::string to_string(MaskKind k) {
    return k == MaskKind::alpha ? "alpha" : k == MaskKind::background ? "background" : "object-index";
}
std::string to_string(ViewKind k) {
    return k == ViewKind::direction ? "direction" : k == ViewKind::vectors ? "vectors" : "position";
}
std::string to_string(LightType t) {
    switch (t) {
        case LightType::directional: return "directional";
        case LightType::point: return "point";
        case LightType::sphere: return "sphere";
        case LightType::rect: return "rect";
    }
    return "?";
}

SceneDescription parse_scene(const std::string& text, const std::string& source_name, const std::string& base_dir) {
    SceneDescription d;
    d.source = source_name;
    d.base_dir = base_dir;
    const Ctx c{source_name, base_dir};
    toml::table root;
    try {
        root = toml::parse(text, source_name);
    } catch (const toml::parse_error& e) {
        std::ostringstream m;
        m << source_name << ":" << e.source().begin.line << ":" << e.source().begin.column << ": TOML syntax: " << e.description();
        throw SceneError(m.str());
    }
    reject_unknown(c, root, "", {"name", "normal", "visibility", "roughness", "anisotropy", "tangent", "mask", "material",
                                 "view", "surface", "light", "comparators", "sampling"});
    if (const toml::node* n = root.get("name")) d.name = string(c, *n, "name");

    // normal
    const toml::table* t = table_at(c, root, "normal");
    if (!t) c.fail("normal", "missing: the [normal] table (file + channels, or value)");
    reject_unknown(c, *t, "normal.", {"file", "channels", "value", "space", "green", "encoding"});
    d.normal.source = vector(c, *t, "normal.", "file", "channels", "value", true);
    d.normal.encoding = encoding(c, *t, "normal.", d.normal.source);
    if (const toml::node* n = t->get("space"))
        d.normal.space = choice<NormalSpace>(c, *n, "normal.space", {{"world", NormalSpace::world}, {"tangent", NormalSpace::tangent}});
    if (const toml::node* n = t->get("green")) {
        if (d.normal.space != NormalSpace::tangent) c.fail("normal.green", "only for space = \"tangent\"");
        d.normal.green_down = choice<bool>(c, *n, "normal.green", {{"+Y", false}, {"-Y", true}});
    }

    // visibility
    t = table_at(c, root, "visibility");
    if (!t) c.fail("visibility", "missing: the [visibility] table (an AO map: file + channel, or value)");
    reject_unknown(c, *t, "visibility.", {"file", "channel", "value", "weighting"});
    d.visibility = scalar(c, *t, "visibility.", 1, true);
    if (const toml::node* n = t->get("weighting"))
        d.ao_weighting = choice<AoWeighting>(c, *n, "visibility.weighting", {{"cosine", AoWeighting::cosine}, {"uniform", AoWeighting::uniform}});

    // roughness
    t = table_at(c, root, "roughness");
    if (!t) c.fail("roughness", "missing: the [roughness] table (file + channel, or value)");
    reject_unknown(c, *t, "roughness.", {"file", "channel", "value", "kind"});
    d.roughness = scalar(c, *t, "roughness.", 0.5, true);
    if (const toml::node* n = t->get("kind"))
        d.roughness_kind = choice<RoughnessKind>(c, *n, "roughness.kind", {{"perceptual", RoughnessKind::perceptual}, {"alpha", RoughnessKind::alpha}});

    if ((t = table_at(c, root, "anisotropy"))) {
        reject_unknown(c, *t, "anisotropy.", {"file", "channel", "value"});
        d.anisotropy = scalar(c, *t, "anisotropy.", 0, true);
    }
    if ((t = table_at(c, root, "tangent"))) {
        reject_unknown(c, *t, "tangent.", {"file", "channels", "value", "encoding"});
        d.has_tangent = true;
        d.tangent = vector(c, *t, "tangent.", "file", "channels", "value", true);
        d.tangent_encoding = encoding(c, *t, "tangent.", d.tangent);
    }
    if ((d.anisotropy.from_image() || d.anisotropy.value != 0) && !d.has_tangent)
        c.fail("tangent", "missing: an anisotropic surface needs a [tangent] direction");

    if ((t = table_at(c, root, "mask"))) {
        reject_unknown(c, *t, "mask.", {"file", "channel", "kind", "threshold", "background", "objects"});
        d.mask.present = true;
        d.mask.source = scalar(c, *t, "mask.", 1, false);
        if (!d.mask.source.from_image()) c.fail("mask.file", "missing: a mask is read from an image");
        if (const toml::node* n = t->get("kind"))
            d.mask.kind = choice<MaskKind>(c, *n, "mask.kind", {{"alpha", MaskKind::alpha}, {"background", MaskKind::background},
                                                                 {"object-index", MaskKind::object_index}});
        if (const toml::node* n = t->get("threshold")) d.mask.threshold = number(c, *n, "mask.threshold");
        if (const toml::node* n = t->get("background")) {
            // inf and -inf are legal here: a depth pass marks its background with infinity.
            if (n->is_floating_point() && std::isinf(n->as_floating_point()->get())) d.mask.background = n->as_floating_point()->get();
            else d.mask.background = number(c, *n, "mask.background");
        }
        // A PNG object-index mask reads stored indices: a palette PNG's indices, not its colours.
        if (d.mask.kind == MaskKind::object_index && png_name(d.mask.source.file) && !t->get("channel")) d.mask.source.channel = "index";
        if (const toml::node* n = t->get("objects")) {
            if (!n->is_array()) c.fail("mask.objects", "must be a list of integers");
            for (const auto& e : *n->as_array()) {
                if (!e.is_integer()) c.fail("mask.objects", "must be a list of integers");
                d.mask.objects.push_back(long(e.as_integer()->get()));
            }
        }
    }
    if ((t = table_at(c, root, "material"))) {
        reject_unknown(c, *t, "material.", {"file", "channel", "names"});
        d.has_material = true;
        d.material = scalar(c, *t, "material.", 0, true);
        if (d.material.from_image() && png_name(d.material.file) && !t->get("channel")) d.material.channel = "index";
        if (const toml::node* n = t->get("names")) d.material_names = strings(c, *n, "material.names");
    }

    t = table_at(c, root, "view");
    if (!t) c.fail("view", "missing: the [view] table (direction, or file + channels, or position + camera)");
    reject_unknown(c, *t, "view.", {"direction", "file", "channels", "encoding", "position", "position_channels", "camera"});
    {
        const int kinds = int(t->get("direction") != nullptr) + int(t->get("file") != nullptr) + int(t->get("position") != nullptr);
        if (kinds != 1) c.fail("view", "give exactly one of direction, file (+ channels: per-pixel view vectors), position (+ position_channels + camera)");
        if (const toml::node* n = t->get("direction")) {
            d.view.kind = ViewKind::direction;
            d.view.direction = vec3(c, *n, "view.direction");
        } else if (t->get("file")) {
            d.view.kind = ViewKind::vectors;
            d.view.vectors = vector(c, *t, "view.", "file", "channels", "", true);
            d.view.encoding = encoding(c, *t, "view.", d.view.vectors);
        } else {
            d.view.kind = ViewKind::position;
            d.view.position = vector(c, *t, "view.", "position", "position_channels", "", true);
            const toml::node* cam = t->get("camera");
            if (!cam) c.fail("view.camera", "missing: the camera position for a position pass");
            d.view.camera = vec3(c, *cam, "view.camera", false);
        }
    }

    if ((t = table_at(c, root, "surface"))) {
        reject_unknown(c, *t, "surface.", {"normal", "tangent", "origin", "width", "height"});
        if (const toml::node* n = t->get("normal")) d.surface.normal = vec3(c, *n, "surface.normal");
        if (const toml::node* n = t->get("tangent")) d.surface.tangent = vec3(c, *n, "surface.tangent");
        if (const toml::node* n = t->get("origin")) d.surface.origin = vec3(c, *n, "surface.origin", false);
        if (const toml::node* n = t->get("width")) d.surface.width = number(c, *n, "surface.width");
        if (const toml::node* n = t->get("height")) d.surface.height = number(c, *n, "surface.height");
        const Vec3& a = d.surface.normal;
        const Vec3& b = d.surface.tangent;
        const double cross = std::hypot(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
        if (cross <= 1e-6 * std::hypot(a.x, a.y, a.z) * std::hypot(b.x, b.y, b.z))
            c.fail("surface.tangent", "must not be parallel to surface.normal");
        if (!(d.surface.width > 0) || !(d.surface.height > 0) || d.surface.width > kMaxCoordinate || d.surface.height > kMaxCoordinate)
            c.fail("surface.width", "width and height must be in (0, 1e30]");
    }

    const toml::node* lights = root.get("light");
    if (!lights || !lights->is_array_of_tables() || lights->as_array()->empty())
        c.fail("light", "missing: at least one [[light]] (type = \"directional\" with direction, or \"point\" with position)");
    std::set<std::string> names;
    if (lights->as_array()->size() > kMaxLights)
        c.fail("light", std::to_string(lights->as_array()->size()) + " lights, more than the limit of " + std::to_string(kMaxLights) +
                            " (each light holds 3 + 2 x comparators full-size float images until the end of the run)");
    for (const auto& e : *lights->as_array()) {
        const toml::table& lt = *e.as_table();
        const std::string p = "light[" + std::to_string(d.lights.size()) + "].";
        reject_unknown(c, lt, p, {"name", "type", "direction", "position", "intensity", "radius", "corners", "lobe"});
        Light l;
        l.name = "light" + std::to_string(d.lights.size());
        if (const toml::node* n = lt.get("name")) l.name = string(c, *n, p + "name");
        if (l.name.empty() || l.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") != std::string::npos)
            c.fail(p + "name", "'" + l.name + "': use letters, digits, '_' and '-' (it names files and EXR layers)");
        if (!names.insert(l.name).second) c.fail(p + "name", "'" + l.name + "' names two lights");
        if (const toml::node* n = lt.get("type"))
            l.type = choice<LightType>(c, *n, p + "type",
                                       {{"directional", LightType::directional}, {"point", LightType::point},
                                        {"sphere", LightType::sphere}, {"rect", LightType::rect}});
        // Each type takes its own keys; another type's key is an error naming what the type takes.
        auto refuse = [&](const char* key, const std::string& why) {
            if (lt.get(key)) c.fail(p + key, why);
        };
        const std::string type = to_string(l.type);
        if (l.type != LightType::directional) refuse("direction", "a " + type + " light has a position, not a direction");
        if (l.type == LightType::directional) {
            const toml::node* n = lt.get("direction");
            if (!n) c.fail(p + "direction", "missing: the direction towards a directional light");
            refuse("position", "a directional light has a direction, not a position");
            l.direction = vec3(c, *n, p + "direction");
        } else if (l.type != LightType::rect) {
            const toml::node* n = lt.get("position");
            if (!n) c.fail(p + "position", "missing: the position of a " + type + " light" + (l.type == LightType::sphere ? " (its centre)" : ""));
            l.position = vec3(c, *n, p + "position", false);
        } else {
            refuse("position", "a rect light has corners, not a position");
        }
        if (l.type != LightType::sphere) refuse("radius", "only a sphere light has a radius");
        if (l.type != LightType::rect) refuse("corners", "only a rect light has corners");
        if (!l.is_area()) refuse("lobe", "only area lights (sphere, rect) take a lobe");
        if (l.type == LightType::sphere) {
            const toml::node* n = lt.get("radius");
            if (!n) c.fail(p + "radius", "missing: the radius of a sphere light");
            l.radius = number(c, *n, p + "radius");
            if (!(l.radius > 0 && l.radius <= kMaxCoordinate)) c.fail(p + "radius", "must be in (0, 1e30], got " + format_number(l.radius));
        }
        if (l.type == LightType::rect) {
            const toml::node* n = lt.get("corners");
            if (!n) c.fail(p + "corners", "missing: the four corners of a rect light, in order around it");
            if (!n->is_array() || n->as_array()->size() != 4) c.fail(p + "corners", "must be a list of 4 positions ([x, y, z] each)");
            for (int k = 0; k < 4; ++k) l.corners[k] = vec3(c, (*n->as_array())[std::size_t(k)], p + "corners", false);
            // The shape checks of area lights (core/area_light.hpp), on the corners seen from a point one
            // side length off the rectangle's centre along its normal: every check but the per-pixel one
            // (a pixel in the rectangle's plane sees no light, and gets 0).
            const Vec3 e1{l.corners[1].x - l.corners[0].x, l.corners[1].y - l.corners[0].y, l.corners[1].z - l.corners[0].z};
            const Vec3 e2{l.corners[3].x - l.corners[0].x, l.corners[3].y - l.corners[0].y, l.corners[3].z - l.corners[0].z};
            Vec3 nrm{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
            const double nl = std::hypot(nrm.x, nrm.y, nrm.z), side = std::max(std::hypot(e1.x, e1.y, e1.z), std::hypot(e2.x, e2.y, e2.z));
            if (nl > 0) nrm = {nrm.x / nl * side, nrm.y / nl * side, nrm.z / nl * side};
            const Vec3 viewer{0.5 * (l.corners[0].x + l.corners[2].x) + nrm.x, 0.5 * (l.corners[0].y + l.corners[2].y) + nrm.y,
                              0.5 * (l.corners[0].z + l.corners[2].z) + nrm.z};
            area::AreaQuery check;
            check.visibility = 0.5;
            check.light.shape = area::LightShape::rect;
            for (int k = 0; k < 4; ++k)
                check.light.rect.corners[k] = {l.corners[k].x - viewer.x, l.corners[k].y - viewer.y, l.corners[k].z - viewer.z};
            try {
                area::validate(check);
            } catch (const std::invalid_argument& e) {
                c.fail(p + "corners", e.what());
            }
        }
        if (const toml::node* n = lt.get("lobe")) l.lobe = choice<area::Lobe>(c, *n, p + "lobe", {{"lambert", area::Lobe::lambert}, {"ggx", area::Lobe::ggx}});
        if (const toml::node* n = lt.get("intensity")) {
            l.intensity = number(c, *n, p + "intensity");
            if (!(l.intensity > 0 && l.intensity <= kMaxIntensity)) c.fail(p + "intensity", "must be in (0, 1e30]");
        }
        d.lights.push_back(l);
    }

    if ((t = table_at(c, root, "comparators"))) {
        reject_unknown(c, *t, "comparators.", {"analytic", "seed_3d", "seed_2d", "lut_size", "lut_samples", "luts"});
        if (const toml::node* n = t->get("analytic")) d.comparators.analytic = strings(c, *n, "comparators.analytic");
        else d.comparators.analytic = analytic::analytic_term_names();
        if (const toml::node* n = t->get("seed_3d")) d.comparators.seed_3d = boolean(c, *n, "comparators.seed_3d");
        if (const toml::node* n = t->get("seed_2d")) d.comparators.seed_2d = boolean(c, *n, "comparators.seed_2d");
        if (const toml::node* n = t->get("lut_size")) d.comparators.lut_size = std::uint32_t(positive(c, *n, "comparators.lut_size", 256));
        if (const toml::node* n = t->get("lut_samples")) d.comparators.lut_samples = positive(c, *n, "comparators.lut_samples", 1 << 22);
        if (const toml::node* n = t->get("luts"))
            for (const auto& f : strings(c, *n, "comparators.luts")) d.comparators.luts.push_back(c.path(f));
    } else {
        d.comparators.analytic = analytic::analytic_term_names();
    }

    if ((t = table_at(c, root, "sampling"))) {
        reject_unknown(c, *t, "sampling.", {"method", "tolerance", "min_samples", "max_samples", "seed", "replicates", "form", "dedup_step",
                                             "tile_pixels", "predict_stride", "area_tolerance"});
        auto& s = d.sampling;
        if (const toml::node* n = t->get("method"))
            s.method = choice<Method>(c, *n, "sampling.method", {{"exact", Method::exact}, {"sampled", Method::sampled}});
        if (const toml::node* n = t->get("tolerance")) {
            s.tolerance = number(c, *n, "sampling.tolerance");
            s.tolerance_given = true;
            if (s.method == Method::exact) {
                if (!(s.tolerance >= 1e-12 && s.tolerance <= 0.5)) c.fail("sampling.tolerance", "must be in [1e-12, 0.5] with method = \"exact\"");
            } else if (!(s.tolerance >= 1e-5 && s.tolerance <= 0.5)) {
                c.fail("sampling.tolerance", "must be in [1e-5, 0.5] with method = \"sampled\"");
            }
        }
        if (!s.tolerance_given) s.tolerance = default_scene_tolerance(s.method);
        if (const toml::node* n = t->get("area_tolerance")) {
            s.area_tolerance = number(c, *n, "sampling.area_tolerance");
            if (!(s.area_tolerance >= 1e-4 && s.area_tolerance <= 0.5)) c.fail("sampling.area_tolerance", "must be in [1e-4, 0.5]");
        }
        if (const toml::node* n = t->get("min_samples")) s.min_samples = positive(c, *n, "sampling.min_samples", 1ULL << 24);
        if (const toml::node* n = t->get("max_samples")) s.max_samples = positive(c, *n, "sampling.max_samples", 1ULL << 26);
        if (const toml::node* n = t->get("seed")) {
            if (!n->is_integer() || n->as_integer()->get() < 0) c.fail("sampling.seed", "must be an integer >= 0");
            s.seed = std::uint64_t(n->as_integer()->get());
        }
        if (const toml::node* n = t->get("replicates")) {
            s.replicates = std::uint32_t(positive(c, *n, "sampling.replicates", 64));
            if (s.replicates != 8 && s.replicates != 16 && s.replicates != 32 && s.replicates != 64)
                c.fail("sampling.replicates", "must be 8, 16, 32 or 64");
        }
        if (const toml::node* n = t->get("form"))
            s.form = choice<Form>(c, *n, "sampling.form", {{"height-correlated", Form::height_correlated}, {"uncorrelated", Form::uncorrelated}});
        if (const toml::node* n = t->get("dedup_step")) {
            s.dedup_step = number(c, *n, "sampling.dedup_step");
            if (!(s.dedup_step >= 0 && s.dedup_step <= kMaxDedupStep))
                c.fail("sampling.dedup_step", "must be in [0, 0.25] (0: no deduplication; a larger grid moves the reference by "
                                              "more than a quarter of the tolerance, docs/scenes.md)");
        }
        if (const toml::node* n = t->get("predict_stride")) s.predict_stride = std::uint32_t(positive(c, *n, "sampling.predict_stride", 1024));
        if (const toml::node* n = t->get("tile_pixels")) {
            if (!n->is_integer() || n->as_integer()->get() < 0) c.fail("sampling.tile_pixels", "must be an integer >= 0 (0: the whole image at once)");
            s.tile_pixels = std::uint64_t(n->as_integer()->get());
        }
        if (s.max_samples < s.min_samples) c.fail("sampling.max_samples", "must be >= min_samples");
    }
    return d;
}

SceneDescription load_scene(const std::string& path) {
    std::string text;
    try {
        text = read_input_file(path, std::uint64_t(1) << 20, "scene description");
    } catch (const InputError& e) {
        throw SceneError(e.what());
    }
    // Relative paths resolve against the folder of the description file itself: a symlinked description
    // is followed to its target, so the images that travel with it are found (and messages say where).
    std::error_code ec;
    fs::path base = fs::path(path).parent_path();
    if (fs::is_symlink(path, ec)) {
        const fs::path target = fs::canonical(path, ec);
        if (!ec) base = target.parent_path();
    }
    return parse_scene(text, path, base.string());
}

}  // namespace ms::scene
