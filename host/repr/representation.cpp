// Representation files (open, kind detection), the builders by name, and the comparator hook.
#include "repr/representation.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>

#include <Imath/half.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>

#include "io/bounded_json.hpp"
#include "io/exr_file.hpp"
#include "io/exr_preflight.hpp"
#include "io/input_file.hpp"
#include "io/input_guard.hpp"
#include "platform/files.hpp"
#include "lut/formats/lut_reader.hpp"
#include "lut/formats/texture_reader.hpp"
#include "lut/formats/texture_writer.hpp"
#include "repr/presets.hpp"
#include "repr/texture_repr.hpp"

namespace ms::repr {

void Representation::write(const std::string& path, bool half) const {
    const lutfmt::TextureFormat format = lutfmt::texture_format_for_path(path, lutfmt::TextureUse::representation);
    lutfmt::write_texture(path, format, texture_file(format, half), half ? lutfmt::PixelEncoding::float16 : lutfmt::PixelEncoding::float32);
}

namespace {
// A representation's texture is a few hundred KiB (docs/representations.md); 2^24 texels (256 MiB as RGBA
// float) bounds what a file can make the reader decode.
constexpr std::uint64_t kMaxReprTexels = std::uint64_t(1) << 24;
}  // namespace

nlohmann::json grid_to_json(const ReprGrid& g) {
    return {{"visibility", g.visibility},          {"n_dot_l", g.n_dot_l},
            {"n_dot_v", g.n_dot_v},                {"roughness", g.roughness},
            {"n_dot_v_warp", to_string(g.warps.n_dot_v)}, {"n_dot_l_warp", to_string(g.warps.n_dot_l)},
            {"visibility_warp", to_string(g.warps.visibility)},
            {"ao_weighting", to_string(g.weighting)}, {"n_dot_l_edge_width", g.edge_width},
            {"texel_placement", to_string(g.placement)}, {"n_dot_v_start", g.n_dot_v_start},
            {"azimuth_warp", g.azimuth_warp}, {"visibility_start", g.visibility_start},
            {"visibility_edge_share", g.visibility_edge_share}, {"visibility_edge_width", g.visibility_edge_width},
            {"visibility_edge_view", g.visibility_edge_view}, {"n_dot_l_edge_view", g.n_dot_l_edge_view}};
}

namespace {

std::uint32_t count_field(const nlohmann::json& j, const char* field, std::uint32_t max) {
    const auto& v = j.at(field);
    if (!v.is_number_unsigned() || v.get<std::uint64_t>() < 1 || v.get<std::uint64_t>() > max)
        throw std::runtime_error(std::string("metadata ") + field + " must be an integer in [1, " + std::to_string(max) + "], not " + v.dump());
    return v.get<std::uint32_t>();
}

}  // namespace

ReprGrid grid_from_json(const nlohmann::json& j) {
    ReprGrid g;
    g.visibility = count_field(j, "visibility", 4096);
    g.n_dot_l = count_field(j, "n_dot_l", 4096);
    g.n_dot_v = count_field(j, "n_dot_v", 4096);
    g.roughness.clear();
    for (const auto& r : j.at("roughness")) {
        if (!r.is_number() || !(r.get<double>() > 0 && r.get<double>() <= 1))
            throw std::runtime_error("metadata grid.roughness: " + r.dump() + " is not in (0, 1]");
        if (!g.roughness.empty() && !(r.get<double>() > g.roughness.back()))
            throw std::runtime_error("metadata grid.roughness must increase");
        g.roughness.push_back(r.get<double>());
    }
    if (g.roughness.empty() || g.roughness.size() > 256) throw std::runtime_error("metadata grid.roughness: 1 to 256 nodes");
    try {
        g.warps.n_dot_v = parse_n_dot_v_warp(j.at("n_dot_v_warp").get<std::string>());
        g.warps.n_dot_l = parse_n_dot_l_warp(j.at("n_dot_l_warp").get<std::string>());
        // Absent in files written before the visibility warp existed: those are linear.
        g.warps.visibility = parse_visibility_warp(j.value("visibility_warp", std::string("linear")));
        g.weighting = parse_ao_weighting(j.at("ao_weighting").get<std::string>());
        // Absent in files written before the edge-roughness warp: its default (unused by other warps).
        if (j.contains("n_dot_l_edge_width")) {
            if (!j.at("n_dot_l_edge_width").is_number() || !(j.at("n_dot_l_edge_width").get<double>() > 0 && j.at("n_dot_l_edge_width").get<double>() <= 100))
                throw std::invalid_argument("n_dot_l_edge_width must be a number in (0, 100]");
            g.edge_width = j.at("n_dot_l_edge_width").get<double>();
        }
        // Absent in files written before the placement existed: those put their texels at cell centres.
        g.placement = parse_texel_placement(j.value("texel_placement", std::string("centres")));
        if (j.contains("n_dot_v_start")) {
            const auto& s = j.at("n_dot_v_start");
            if (!s.is_number() || !(s.get<double>() >= 0 && s.get<double>() < 1))
                throw std::invalid_argument("n_dot_v_start must be a number in [0, 1)");
            g.n_dot_v_start = s.get<double>();
        }
        // Absent in files written before the visibility start: their first texel is the first cell centre.
        if (j.contains("visibility_start")) {
            const auto& a = j.at("visibility_start");
            if (!a.is_number() || !(a.get<double>() >= 0 && a.get<double>() < 0.5))
                throw std::invalid_argument("visibility_start must be a number in [0, 0.5)");
            g.visibility_start = a.get<double>();
        }
        // Absent in files written before the far-side warp: their series is in cos phi.
        if (j.contains("azimuth_warp")) {
            const auto& a = j.at("azimuth_warp");
            if (!a.is_number() || !(a.get<double>() >= 0 && a.get<double>() <= 1000))
                throw std::invalid_argument("azimuth_warp must be a number in [0, 1000]");
            g.azimuth_warp = a.get<double>();
        }
        // Absent in files written before the view-dependent widths and the edge-roughness visibility
        // warp: no view factor (the NdotL width k alpha max(sin theta_c, alpha) alone); the visibility
        // constants are read by that warp only, which such files do not name.
        auto number = [&](const char* key, double lo, double hi, bool lo_open, double& out) {
            if (!j.contains(key)) return;
            const auto& x = j.at(key);
            if (!x.is_number() || !((lo_open ? x.get<double>() > lo : x.get<double>() >= lo) && x.get<double>() <= hi))
                throw std::invalid_argument(std::string(key) + " must be a number in " + (lo_open ? "(" : "[") + shader_literal(lo) + ", " +
                                            shader_literal(hi) + "]");
            out = x.get<double>();
        };
        number("visibility_edge_share", 0, 100, false, g.visibility_edge_share);
        number("visibility_edge_width", 0, 100, true, g.visibility_edge_width);
        number("visibility_edge_view", 0, 100, false, g.visibility_edge_view);
        number("n_dot_l_edge_view", 0, 100, false, g.n_dot_l_edge_view);
        if (g.warps.visibility == VisibilityWarp::edge_roughness && g.warps.n_dot_l != NdotLWarp::edge_roughness)
            throw std::invalid_argument("the edge-roughness visibility warp needs the edge-roughness NdotL warp");
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(std::string("metadata grid: ") + e.what());
    }
    return g;
}

namespace {

// The file's "microshadow" metadata when it is a representation file; nullopt for any other file
// (a LUT, another EXR, not an EXR).

std::optional<nlohmann::json> representation_metadata(const Imf::Header& header) {
    const auto* attr = header.findTypedAttribute<Imf::StringAttribute>("microshadow");
    if (!attr) return std::nullopt;
    const nlohmann::json meta = parse_bounded_json(attr->value(), "the \"microshadow\" attribute");
    if (!meta.is_object() || meta.value("kind", std::string()) != "representation") return std::nullopt;
    return meta;
}

bool is_exr(const std::string& path) {
    // OpenEXR's magic number: a file that is not an EXR is not a representation (no OpenEXR exception).
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    unsigned char magic[4] = {0, 0, 0, 0};
    const bool ok = std::fread(magic, 1, 4, f) == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01;
    std::fclose(f);
    return ok;
}

// KTX 2.0's identifier (the specification's "File Structure"): the first 12 bytes of every KTX2 file.
constexpr unsigned char kKtx2Identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};

bool is_ktx2(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    unsigned char magic[12] = {};
    const bool ok = std::fread(magic, 1, 12, f) == 12 && std::memcmp(magic, kKtx2Identifier, 12) == 0;
    std::fclose(f);
    return ok;
}

// A KTX2 file of `Representation::write` read back: the "microshadow" metadata of its key/value
// data and its one level as RGBA floats. Only what write writes as KTX2 is accepted (RGBA16F or RGBA32F,
// one face, one level, no array, no supercompression); every offset and length is checked against the
// file's size before it is read. Throws std::runtime_error saying what is wrong.
struct Ktx2Representation {
    nlohmann::json metadata;
    Texture3D texture;
};

Ktx2Representation read_ktx2_representation(const std::string& path) {
    const std::string b = read_input_file(path, std::uint64_t(1) << 28, "representation file");
    auto u32 = [&](std::size_t at) {
        std::uint32_t v;
        std::memcpy(&v, b.data() + at, 4);
        return v;
    };
    auto u64 = [&](std::size_t at) {
        std::uint64_t v;
        std::memcpy(&v, b.data() + at, 8);
        return v;
    };
    // Header (80 bytes) and the level index of one level (24 bytes).
    if (b.size() < 104 || std::memcmp(b.data(), kKtx2Identifier, 12) != 0) throw std::runtime_error("not a KTX2 file");
    const std::uint32_t vk_format = u32(12), type_size = u32(16);
    if (!((vk_format == 97 && type_size == 2) || (vk_format == 109 && type_size == 4)))
        throw std::runtime_error("vkFormat " + std::to_string(vk_format) + " is not RGBA16F (97) or RGBA32F (109)");
    if (u32(32) != 0 || u32(36) != 1 || u32(40) != 1 || u32(44) != 0)
        throw std::runtime_error("not one face, one level, no array layers and no supercompression");
    const std::uint64_t kvd_offset = u32(56), kvd_length = u32(60);
    if (kvd_offset + kvd_length > b.size()) throw std::runtime_error("key/value data beyond the end of the file");
    std::optional<nlohmann::json> meta;
    for (std::uint64_t at = kvd_offset; at + 4 <= kvd_offset + kvd_length;) {
        const std::uint64_t n = u32(std::size_t(at));
        if (at + 4 + n > kvd_offset + kvd_length) throw std::runtime_error("a key/value entry runs past the key/value data");
        const std::string entry = b.substr(std::size_t(at + 4), std::size_t(n));
        const std::size_t nul = entry.find('\0');
        if (nul != std::string::npos && entry.compare(0, nul, "microshadow") == 0) {
            std::string value = entry.substr(nul + 1);
            if (!value.empty() && value.back() == '\0') value.pop_back();
            meta = parse_bounded_json(value, "the \"microshadow\" key/value entry");
        }
        at += 4 + (n + 3) / 4 * 4;  // entries are padded to 4 bytes
    }
    if (!meta || !meta->is_object() || meta->value("kind", std::string()) != "representation")
        throw std::runtime_error("no \"microshadow\" metadata of kind \"representation\" in the key/value data");
    Ktx2Representation out;
    out.metadata = *meta;
    Texture3D& t = out.texture;
    const auto& tex = meta->at("texture");
    t.width = count_field(tex, "width", 1 << 16);
    t.height = count_field(tex, "height", 4096);
    t.depth = count_field(tex, "depth", 1 << 16);
    if (u32(20) != t.width || u32(24) != t.height || std::max<std::uint32_t>(u32(28), 1) != t.depth)
        throw std::runtime_error("pixelWidth/Height/Depth do not match the metadata's texture");
    const std::uint64_t texels = std::uint64_t(t.width) * t.height * t.depth;
    if (texels * 4 > (std::uint64_t(1) << 26)) throw std::runtime_error("texture larger than 2^24 texels");
    const std::uint64_t offset = u64(80), length = u64(88);
    if (length != texels * 4 * type_size || offset > b.size() || length > b.size() - offset)
        throw std::runtime_error("level 0 is not width x height x depth RGBA texels inside the file");
    t.texels.resize(std::size_t(texels * 4));
    for (std::size_t i = 0; i < t.texels.size(); ++i) {
        if (type_size == 4) {
            std::memcpy(&t.texels[i], b.data() + offset + 4 * i, 4);
        } else {
            std::uint16_t bits;
            std::memcpy(&bits, b.data() + offset + 2 * i, 2);
            Imath::half h;
            h.setBits(bits);
            t.texels[i] = float(h);
        }
        if (!std::isfinite(t.texels[i])) throw std::runtime_error("texel " + std::to_string(i / 4) + " is not finite");
    }
    return out;
}

// The metadata's texture.channels: 1 to 4 strings.
std::vector<std::string> metadata_channels(const nlohmann::json& tex) {
    const auto it = tex.find("channels");
    if (it == tex.end() || !it->is_array() || it->empty() || it->size() > 4)
        throw std::runtime_error("metadata texture.channels: 1 to 4 names");
    std::vector<std::string> names;
    for (const auto& n : *it) {
        if (!n.is_string()) throw std::runtime_error("metadata texture.channels: names must be strings");
        names.push_back(n.get<std::string>());
    }
    return names;
}

// Builds the representation and checks what the file gave against it (its channels, each texel's
// range): a file edited or damaged after its bake is refused, not looked up.
std::unique_ptr<Representation> make_representation(const nlohmann::json& meta, Texture3D t,
                                                    const std::vector<std::string>& channels) {
    const ReprGrid grid = grid_from_json(meta.at("grid"));
    const std::string kind = meta.value("representation", std::string());
    // The anisotropic kind fits surfaces, not azimuth nodes (its file records 0).
    const std::uint32_t azimuth_nodes = kind == "anisotropic-harmonics" ? 0 : count_field(meta, "azimuth_nodes", 256);
    std::unique_ptr<Representation> r;
    if (kind == "azimuth-axis") r = make_azimuth_axis(grid, azimuth_nodes, std::move(t), meta);
    else if (kind == "azimuth-harmonics") r = make_azimuth_harmonics(grid, azimuth_nodes, std::move(t), meta);
    else if (kind == "anisotropic-harmonics") r = make_anisotropic_harmonics(grid, std::move(t), meta);
    else if (kind == "anisotropic-mapped-harmonics") r = make_azimuth_harmonics(grid, azimuth_nodes, std::move(t), meta, true);
    else if (kind == "anisotropic-corrected-harmonics") r = make_anisotropic_corrected(grid, azimuth_nodes, std::move(t), meta);
    else throw std::runtime_error("unknown representation '" + kind + "'");
    static_cast<const TextureRepresentation&>(*r).check_contents(channels);
    return r;
}

// A DDS of `Representation::write` read back: its metadata from the sidecar `<file>.json`, its
// one level through lut/formats/texture_reader.hpp (every size checked against the file).
Ktx2Representation read_dds_representation(const std::string& path) {
    lutfmt::TextureFile f = lutfmt::read_dds_texture(path, kMaxReprTexels);
    const nlohmann::json& meta = f.texture.metadata;
    if (!meta.is_object() || meta.value("kind", std::string()) != "representation")
        throw std::runtime_error("no metadata of kind \"representation\" in its sidecar " + path + ".json");
    if (f.texture.faces != 1 || f.texture.levels.size() != 1) throw std::runtime_error("not one face and one level");
    if (f.encoding != lutfmt::PixelEncoding::float32 && f.encoding != lutfmt::PixelEncoding::float16)
        throw std::runtime_error("texels are " + lutfmt::to_string(f.encoding) + ", not RGBA16F or RGBA32F");
    Ktx2Representation out;
    out.metadata = meta;
    Texture3D& t = out.texture;
    const auto& tex = meta.at("texture");
    t.width = count_field(tex, "width", 1 << 16);
    t.height = count_field(tex, "height", 4096);
    t.depth = count_field(tex, "depth", 1 << 16);
    if (f.texture.width != t.width || f.texture.height != t.height || f.texture.depth != t.depth)
        throw std::runtime_error("the DDS size does not match the metadata's texture");
    t.texels = std::move(f.texture.levels[0]);
    for (std::size_t i = 0; i < t.texels.size(); ++i)
        if (!std::isfinite(t.texels[i])) throw std::runtime_error("texel " + std::to_string(i / 4) + " is not finite");
    return out;
}

// A LUT given where a representation is expected: a one-line pointer to the commands that read it.
void refuse_lut(const std::string& path) {
    nlohmann::json meta;
    try {
        meta = lutfmt::read_file_metadata(path);
    } catch (const std::exception&) {
        return;  // unreadable as anything: the caller's own message says so
    }
    if (meta.is_object() && meta.contains("axes") && meta.contains("channels") && meta.value("kind", std::string()) != "representation")
        throw std::runtime_error("a LUT (written by `microshadow bake`), not a representation: use `microshadow lut info|export` "
                                 "or `microshadow shader` for it");
}

}  // namespace

bool is_representation_file(const std::string& path) {
    platform::FileStatus st;
    if (platform::path_status(path, st) != 0 || st.kind != platform::FileKind::regular) return false;  // a FIFO would block open()
    if (lutfmt::has_dds_magic(path)) {
        try {
            read_dds_representation(path);
            return true;
        } catch (const std::exception&) {
            return false;
        }
    }
    if (is_ktx2(path)) {
        try {
            read_ktx2_representation(path);
            return true;
        } catch (const std::exception&) {
            return false;
        }
    }
    if (!is_exr(path)) return false;
    try {
        exr::preflight_image(path, kMaxReprTexels);
        Imf::InputFile file(path.c_str());
        return representation_metadata(file.header()).has_value();
    } catch (const std::exception&) {
        return false;
    }
}

std::unique_ptr<Representation> open_representation(const std::string& path) {
    try {
        require_regular_file(path, "representation");  // a FIFO would block open() beyond the reach of signals
        note_input(path);
        refuse_lut(path);
        if (lutfmt::has_dds_magic(path)) {
            Ktx2Representation d = read_dds_representation(path);
            const auto channels = metadata_channels(d.metadata.at("texture"));
            return make_representation(d.metadata, std::move(d.texture), channels);
        }
        if (is_ktx2(path)) {
            Ktx2Representation k = read_ktx2_representation(path);
            const auto channels = metadata_channels(k.metadata.at("texture"));
            return make_representation(k.metadata, std::move(k.texture), channels);
        }
        if (!is_exr(path)) throw std::runtime_error("neither an OpenEXR, a KTX2 nor a DDS file");
        // Claims the file cannot hold are refused before OpenEXR allocates them (io/exr_preflight.hpp).
        exr::preflight_image(path, kMaxReprTexels);
        Imf::InputFile file(path.c_str());
        const auto meta = representation_metadata(file.header());
        if (!meta) throw std::runtime_error("no \"microshadow\" metadata of kind \"representation\"");
        const auto& tex = meta->at("texture");
        Texture3D t;
        t.width = count_field(tex, "width", 1 << 16);
        t.height = count_field(tex, "height", 4096);
        t.depth = count_field(tex, "depth", 1 << 16);
        const std::uint64_t texels = std::uint64_t(t.width) * t.height * t.depth;
        if (texels * 4 > (std::uint64_t(1) << 26)) throw std::runtime_error("texture larger than 2^24 texels");
        const Imath::Box2i dw = file.header().dataWindow();
        if (std::uint64_t(dw.max.x - dw.min.x + 1) != t.width || std::uint64_t(dw.max.y - dw.min.y + 1) != std::uint64_t(t.height) * t.depth)
            throw std::runtime_error("image size does not match the metadata's texture (width, height x depth)");
        const std::vector<std::string> names = metadata_channels(tex);
        t.texels.assign(texels * 4, 0.0f);
        Imf::FrameBuffer fb;
        const std::size_t stride = 4 * sizeof(float);
        char* base = exr::frame_base(t.texels.data(), dw.min.x, dw.min.y, stride, stride * t.width);
        for (std::size_t c = 0; c < names.size(); ++c) {
            if (!file.header().channels().findChannel(names[c])) throw std::runtime_error("no channel " + names[c]);
            fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), stride, stride * t.width));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        for (std::size_t i = 0; i < texels; ++i) {
            for (std::size_t c = names.size(); c < 4; ++c) t.texels[i * 4 + c] = t.texels[i * 4 + names.size() - 1];
            for (std::size_t c = 0; c < 4; ++c)
                if (!std::isfinite(t.texels[i * 4 + c]))
                    throw std::runtime_error("texel " + std::to_string(i) + " channel " + names[std::min(c, names.size() - 1)] + " is not finite");
        }
        return make_representation(*meta, std::move(t), names);
    } catch (const std::exception& e) {
        throw std::runtime_error(path + ": " + e.what());
    }
}

std::vector<std::string> representation_kinds() { return {"azimuth-axis", "azimuth-harmonics"}; }

std::unique_ptr<Representation> build_representation(const std::string& kind, const AzimuthBake& bake) {
    if (kind == "azimuth-axis") return build_azimuth_axis(bake);
    if (kind == "azimuth-harmonics") return build_azimuth_harmonics(bake);
    if (kind == "anisotropic-mapped-harmonics") return build_azimuth_harmonics(bake, true);
    throw std::invalid_argument("unknown representation '" + kind + "' (valid: azimuth-axis, azimuth-harmonics)");
}

}  // namespace ms::repr
