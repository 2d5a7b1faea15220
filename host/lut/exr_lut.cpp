#include "lut/exr_lut.hpp"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <Imath/half.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "core/lookup_domain.hpp"
#include "io/atomic_file.hpp"
#include "io/bounded_json.hpp"
#include "io/exr_file.hpp"
#include "io/exr_preflight.hpp"
#include "io/text.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/texture_writer.hpp"

namespace ms {

namespace {
const char* const kChannelNames[4] = {"R", "G", "B", "A"};
const char* const kAxisNames[3] = {"visibility", "n_dot_l", "n_dot_v"};

// Largest axis count and texel count a LUT file may claim before anything is allocated: above any
// bake worth sampling (2^28 texels is a 645^3 LUT, 4 GiB of floats at 4 channels), below what would
// overflow or exhaust memory when a hostile file's numbers are multiplied.
// Values (texels x channels) a LUT file may hold: 2^26 floats, 256 MB, a 256^3 x 4 atlas. The reader
// allocates them before reading, so a 4 KB crafted file claiming 2^28 texels x 4 channels asked for
// 4 GB (fuzz_lut_file ran out of memory).
constexpr std::uint64_t kMaxAxisCount = 65536, kMaxValues = std::uint64_t(1) << 26;

nlohmann::json axis_json(const LutAxis& a) {
    return {{"name", a.name}, {"min", a.min}, {"max", a.max}, {"count", a.count}, {"texel", to_string(a.texel)}};
}
}  // namespace

std::string exr_channel_name(double roughness, int digits) {
    // No '.' in the name: OpenEXR tools read "a.b" as channel b of layer a. 'p' stands for the point.
    char buf[48];
    std::snprintf(buf, sizeof buf, "roughness_%.*g", digits, roughness);
    std::string s = buf;
    for (char& c : s)
        if (c == '.') c = 'p';
    return s;
}

std::vector<std::string> exr_channel_names(const std::vector<LutChannel>& channels) {
    for (int digits : {6, 17}) {
        std::vector<std::string> names;
        for (const auto& c : channels) names.push_back(exr_channel_name(c.roughness, digits));
        std::vector<std::string> sorted = names;
        std::sort(sorted.begin(), sorted.end());
        if (std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end()) return names;
    }
    throw std::invalid_argument("write_lut: two channels have the same roughness");
}


LookupDomain lut_domain(const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels) {
    LookupDomain d;
    if (axes.size() == 3) {
        d.visibility_min = axes[0].min;
        d.visibility_max = axes[0].max;
        if (axes[2].count > 1) {
            d.n_dot_v_min = axes[2].min;
            d.n_dot_v_max = axes[2].max;
        }
    }
    if (!channels.empty()) {
        d.roughness_min = d.roughness_max = channels[0].roughness;
        for (const auto& c : channels) {
            d.roughness_min = std::min(d.roughness_min, c.roughness);
            d.roughness_max = std::max(d.roughness_max, c.roughness);
        }
    }
    return d;
}

void write_lut(const std::string& path, const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels,
               const std::vector<float>& data, const nlohmann::json& metadata, bool half) {
    if (axes.size() != 3) throw std::invalid_argument("write_lut: need the visibility, n_dot_l and n_dot_v axes");
    if (channels.empty() || channels.size() > 4) throw std::invalid_argument("write_lut: 1 to 4 channels");
    for (std::size_t c = 0; c < channels.size(); ++c)
        if (channels[c].name != kChannelNames[c]) throw std::invalid_argument("write_lut: channels must be R, G, B, A in order");
    const std::size_t width = axes[0].count, height = std::size_t(axes[1].count) * axes[2].count;
    if (width == 0 || height == 0 || data.size() != width * height * channels.size())
        throw std::invalid_argument("write_lut: data size does not match the axes");

    // The channels are R, G, B, A: what engines' EXR importers read as one RGBA texture. The roughness of
    // each is in the metadata ("channels") and in the typed attributes microshadow.roughness.<R|G|B|A>;
    // "oiio:UnassociatedAlpha" below keeps image tools from taking A for premultiplied alpha.
    std::vector<std::string> exr_names;
    for (const auto& ch : channels) exr_names.push_back(ch.name);
    nlohmann::json meta = metadata;
    meta["axes"] = nlohmann::json::array();
    for (const auto& a : axes) meta["axes"].push_back(axis_json(a));
    meta["channels"] = nlohmann::json::array();
    for (std::size_t c = 0; c < channels.size(); ++c) {
        const auto& ch = channels[c];
        meta["channels"].push_back({{"name", ch.name}, {"exr_channel", exr_names[c]}, {"texture_channel", ch.name},
                                    {"roughness", ch.roughness}, {"alpha_x", ch.alpha_x}, {"alpha_y", ch.alpha_y}});
    }
    if (!meta.contains("domain"))
        meta["domain"] = lut_domain(axes, channels).to_json("the lookups this LUT was baked for; outside, clamp-to-edge answers");
    meta["file_format"] = "exr";
    lutfmt::add_error_budget(meta, data, half ? lutfmt::PixelEncoding::float16 : lutfmt::PixelEncoding::float32);

    // The image for the one texture writer (lut/formats/texture_writer.hpp): the atlas, NdotV slices
    // one under the other.
    lutfmt::TextureData t;
    t.width = std::uint32_t(width);
    t.height = std::uint32_t(height);
    t.channels = std::uint32_t(channels.size());
    t.levels = {data};
    t.metadata = std::move(meta);
    t.channel_names = exr_names;
    // A 4-channel image written as PNG (or TIFF, ...) by OpenImageIO gets its 4th channel as alpha
    // whatever its name, and OpenImageIO divides by it unless the data say they are unassociated:
    // this attribute (read by OpenImageIO from any EXR) says so; nothing is premultiplied here.
    t.exr_attributes.push_back({"oiio:UnassociatedAlpha", 1});
    for (std::size_t i = 0; i < 3; ++i) {
        const std::string p = std::string("microshadow.axis.") + kAxisNames[i] + ".";
        t.exr_attributes.push_back({p + "min", axes[i].min});
        t.exr_attributes.push_back({p + "max", axes[i].max});
        t.exr_attributes.push_back({p + "count", int(axes[i].count)});
        t.exr_attributes.push_back({p + "texel", to_string(axes[i].texel)});
    }
    for (const auto& c : channels) t.exr_attributes.push_back({"microshadow.roughness." + c.name, c.roughness});
    lutfmt::write_exr_texture(path, t, half);
}

namespace {

// A JSON number that must be finite; `field` names it in the error.
double finite_number(const nlohmann::json& j, const std::string& field) {
    if (!j.is_number()) throw std::runtime_error("metadata " + field + " must be a number, not " + j.dump());
    const double v = j.get<double>();
    if (!std::isfinite(v)) throw std::runtime_error("metadata " + field + " must be finite");
    return v;
}

// An axis count: checked as an integer in range before anything multiplies it (a JSON 2147483649 must
// not pass as uint32 and wrap a product; 32.5 or -1 must not be truncated into a count).
std::uint32_t axis_count(const nlohmann::json& j, const std::string& field) {
    const std::string range = " is outside [1, " + std::to_string(kMaxAxisCount) + "]";
    if (!j.is_number_integer()) throw std::runtime_error("metadata " + field + " must be an integer, not " + j.dump());
    if (!j.is_number_unsigned() && j.get<std::int64_t>() < 1) throw std::runtime_error("metadata " + field + " = " + j.dump() + range);
    const auto v = j.get<std::uint64_t>();
    if (v < 1 || v > kMaxAxisCount) throw std::runtime_error("metadata " + field + " = " + j.dump() + range);
    return std::uint32_t(v);
}

// The coverage record of a partial bake, {"unbaked": "NaN", "rows": [[channel, n_dot_v index, first
// row, end row], ...], ...}, as one flag per (NdotV slice, channel, NdotL row): index (ivv * channels +
// c) * rows + il. Empty when the file has no record (every texel baked).
std::vector<std::uint8_t> coverage_rows(const nlohmann::json& meta, const std::vector<LutAxis>& axes, std::size_t channels) {
    if (!meta.contains("coverage")) return {};
    const auto& cov = meta.at("coverage");
    if (!cov.is_object() || cov.value("unbaked", "") != "NaN" || !cov.contains("rows") || !cov.at("rows").is_array())
        throw std::runtime_error("metadata coverage must be {\"unbaked\": \"NaN\", \"rows\": [[channel, n_dot_v, first, end], ...]}");
    const std::uint32_t rows = axes[1].count, slices = axes[2].count;
    std::vector<std::uint8_t> baked(std::size_t(rows) * slices * channels, 0);
    for (const auto& run : cov.at("rows")) {
        if (!run.is_array() || run.size() != 4) throw std::runtime_error("metadata coverage.rows: entries are [channel, n_dot_v, first, end]");
        std::uint64_t f[4];
        for (int k = 0; k < 4; ++k) {
            if (!run[k].is_number_unsigned()) throw std::runtime_error("metadata coverage.rows: " + run.dump() + " is not 4 indices");
            f[k] = run[k].get<std::uint64_t>();
        }
        if (f[0] >= channels || f[1] >= slices || f[2] >= f[3] || f[3] > rows)
            throw std::runtime_error("metadata coverage.rows: " + run.dump() + " is outside the axes");
        for (std::uint64_t il = f[2]; il < f[3]; ++il) baked[(f[1] * channels + f[0]) * rows + il] = 1;
    }
    return baked;
}

}  // namespace

LutFile lut_from_metadata(const nlohmann::json& metadata, std::vector<std::string>* exr_names) {
    LutFile lut;
    lut.metadata = metadata;
    if (!lut.metadata.is_object()) throw std::runtime_error("the \"microshadow\" metadata is not a JSON object");
    // Other files of this tool carry the same "microshadow" metadata: say which command reads them
    // instead of a missing-key message.
    if (lut.metadata.value("kind", std::string()) == "representation")
        throw WrongFileKind("a representation file (written by `microshadow repr bake`), not a LUT: "
                            "use `microshadow repr info|shader|export` for it");
    if (!lut.metadata.contains("axes") || !lut.metadata.contains("channels"))
        throw WrongFileKind("not a micro-shadowing LUT: its \"microshadow\" metadata has no axes and channels" +
                            (lut.metadata.contains("file_format") ? " (file_format " + lut.metadata.at("file_format").dump() + ")"
                                                                  : std::string()));
    const auto& axes = lut.metadata.at("axes");
    if (!axes.is_array() || axes.size() != 3) throw std::runtime_error("metadata must list 3 axes");
    for (std::size_t i = 0; i < 3; ++i) {
        const std::string f = "axes[" + std::to_string(i) + "]";
        LutAxis a;
        a.name = axes[i].at("name").get<std::string>();
        if (a.name != kAxisNames[i]) throw std::runtime_error("axis " + std::to_string(i) + " must be " + kAxisNames[i]);
        a.min = finite_number(axes[i].at("min"), f + ".min (" + a.name + ")");
        a.max = finite_number(axes[i].at("max"), f + ".max (" + a.name + ")");
        a.count = axis_count(axes[i].at("count"), f + ".count (" + a.name + ")");
        a.texel = parse_texel_convention(axes[i].at("texel").get<std::string>());
        // Every axis is a cosine or a visibility: a range outside [0, 1], or reversed, is a corrupt file.
        if (a.min < 0 || a.max > 1 || a.min > a.max || (a.min == a.max && a.count > 1))
            throw std::runtime_error("metadata " + f + " (" + a.name + ") range [" + format_g(a.min, 9) + ", " +
                                     format_g(a.max, 9) + "] must satisfy 0 <= min < max <= 1");
        lut.axes.push_back(a);
    }
    const auto& channels = lut.metadata.at("channels");
    if (!channels.is_array() || channels.empty() || channels.size() > 4)
        throw std::runtime_error("metadata must list 1 to 4 channels");
    for (std::size_t i = 0; i < channels.size(); ++i) {
        const auto& c = channels[i];
        const std::string f = "channels[" + std::to_string(i) + "]";
        LutChannel ch;
        ch.name = c.at("name").get<std::string>();
        ch.roughness = finite_number(c.at("roughness"), f + ".roughness");
        ch.alpha_x = finite_number(c.at("alpha_x"), f + ".alpha_x");
        ch.alpha_y = finite_number(c.at("alpha_y"), f + ".alpha_y");
        if (!(ch.roughness > 0 && ch.roughness <= 1))
            throw std::runtime_error("metadata " + f + ".roughness = " + format_g(ch.roughness, 9) + " is outside (0, 1]");
        if (!(ch.alpha_x > 0) || !(ch.alpha_y > 0))
            throw std::runtime_error("metadata " + f + ".alpha_x/alpha_y must be > 0");
        if (ch.name != kChannelNames[i]) throw std::runtime_error("metadata " + f + ".name must be " + kChannelNames[i]);
        // Older files stored the roughness channels as R, G, B, A; newer ones name them (exr_channel).
        // Both read the same.
        if (exr_names) exr_names->push_back(c.contains("exr_channel") ? c.at("exr_channel").get<std::string>() : ch.name);
        lut.channels.push_back(ch);
    }
    // What every command that uses a LUT (lookups, shaders, exports) relies on, checked once here so
    // that no command writes a file another one refuses: distinct roughness channels, a known AO
    // weighting, a lookup domain that parses.
    for (std::size_t i = 0; i < lut.channels.size(); ++i)
        for (std::size_t k = 0; k < i; ++k)
            if (lut.channels[i].roughness == lut.channels[k].roughness)
                throw std::runtime_error("metadata channels[" + std::to_string(k) + "] and channels[" + std::to_string(i) +
                                         "] hold the same roughness " + format_g(lut.channels[i].roughness, 9));
    if (lut.metadata.contains("ao_weighting")) {
        const auto& w = lut.metadata.at("ao_weighting");
        if (!w.is_string() || (w != "cosine" && w != "uniform"))
            throw std::runtime_error("metadata ao_weighting " + w.dump() + " is neither \"cosine\" nor \"uniform\"");
    }
    if (lut.metadata.contains("domain")) LookupDomain::from_json(lut.metadata.at("domain"), "LUT metadata");
    const std::uint64_t want_w = lut.axes[0].count, want_h = std::uint64_t(lut.axes[1].count) * lut.axes[2].count;
    if (want_w * want_h * lut.channels.size() > kMaxValues)
        throw std::runtime_error("metadata axes claim " + std::to_string(want_w * want_h) + " texels x " +
                                 std::to_string(lut.channels.size()) + " channels, more than the limit of " +
                                 std::to_string(kMaxValues) + " values");
    lut.width = std::uint32_t(want_w);
    lut.height = std::uint32_t(want_h);
    return lut;
}

void check_lut_texels(const LutFile& lut) {
    const std::size_t nc = lut.channels.size();
    if (lut.data.size() != std::size_t(lut.width) * lut.height * nc)
        throw std::runtime_error("the texels do not fill the " + std::to_string(lut.width) + " x " + std::to_string(lut.height) +
                                 " x " + std::to_string(nc) + " image the axes describe");
    // A partial bake (`bake --scene`) records the rows it baked; every other texel must be NaN, so that
    // a lookup touching it is refused (lookup.cpp) instead of blending a stale value.
    const std::vector<std::uint8_t> baked = coverage_rows(lut.metadata, lut.axes, nc);
    const std::uint32_t rows = lut.axes[1].count;
    // Every texel is a fraction of facets: NaN, infinity or a value outside [0, 1] is corruption that
    // a lookup would otherwise blend silently into its results.
    for (std::size_t i = 0; i < lut.data.size(); ++i) {
        const float v = lut.data[i];
        const std::size_t texel = i / nc, c = i % nc, y = texel / lut.width;
        if (!baked.empty() && !baked[(y / rows * nc + c) * rows + y % rows]) {
            if (!std::isnan(v))
                throw std::runtime_error("texel (x " + std::to_string(texel % lut.width) + ", y " + std::to_string(y) +
                                         ") of channel " + lut_channel_label(lut, c) + " is " + format_g(v, 9) +
                                         " where the coverage record says unbaked (must be NaN)");
            continue;
        }
        if (!(v >= 0.0f && v <= 1.0f))
            throw std::runtime_error("texel (x " + std::to_string(texel % lut.width) + ", y " + std::to_string(y) + ") of channel " +
                                     lut_channel_label(lut, c) + " is " + format_g(v, 9) + ", not in [0, 1]");
    }
}

bool is_partial_bake(const LutFile& lut) { return lut.metadata.is_object() && lut.metadata.contains("coverage"); }

LutFile read_exr_lut(const std::string& path) {
    LutFile lut;
    try {
        // OpenEXR 3.1 allocates what a header's attributes and offset tables claim before it knows the
        // file holds them (fuzz_lut_file: 1.7 GB asked by a 4 KB file): the preflight proves every claim
        // fits in the file, and the image (and a tile) is bounded by kMaxValues before OpenEXR decodes it.
        const exr::FileSummary summary = exr::preflight_image(path, kMaxValues);
        if (summary.parts.size() != 1) throw std::runtime_error("a multi-part file: a LUT is one part");
        const exr::PartSummary& part = summary.parts.front();
        if (part.type != "scanlineimage" && part.type != "tiledimage")
            throw std::runtime_error("a " + part.type + " part: a LUT is a flat (scan-line or tiled) image");
        const auto values = [&](std::int64_t w, std::int64_t h) { return std::uint64_t(w) * std::uint64_t(h) * std::max(part.channels, 1u); };
        if (values(part.width, part.height) > kMaxValues || values(part.tile_width, part.tile_height) > kMaxValues)
            throw std::runtime_error("a " + std::to_string(part.width) + " x " + std::to_string(part.height) + " image of " +
                                     std::to_string(part.channels) + " channels is more than the limit of " +
                                     std::to_string(kMaxValues) + " values");
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        const auto* attr = header.findTypedAttribute<Imf::StringAttribute>("microshadow");
        if (!attr) throw WrongFileKind("no \"microshadow\" header attribute: not a microshadow LUT");
        std::vector<std::string> exr_names;
        lut = lut_from_metadata(parse_bounded_json(attr->value(), "the \"microshadow\" attribute"), &exr_names);
        const Imath::Box2i dw = header.dataWindow();
        const std::int64_t w = std::int64_t(dw.max.x) - dw.min.x + 1, h = std::int64_t(dw.max.y) - dw.min.y + 1;
        if (w != std::int64_t(lut.width) || h != std::int64_t(lut.height))
            throw std::runtime_error("image size " + std::to_string(w) + "x" + std::to_string(h) + " does not match the axes (" +
                                     std::to_string(lut.width) + "x" + std::to_string(lut.height) + ")");
        const std::size_t nc = lut.channels.size();
        // Every channel in one type, HALF or FLOAT, as the writer stores them: a channel whose type was
        // changed in the header alone (HALF relabelled FLOAT) makes OpenEXR read past its decoded data.
        for (std::size_t c = 0; c < nc; ++c) {
            const Imf::Channel* ch = header.channels().findChannel(exr_names[c]);
            if (!ch) throw std::runtime_error("missing channel " + exr_names[c] + " (channels[" + std::to_string(c) + "])");
            if (ch->type != Imf::HALF && ch->type != Imf::FLOAT)
                throw std::runtime_error("channel " + exr_names[c] + " is UINT; a LUT's channels are HALF or FLOAT");
            if (ch->xSampling != 1 || ch->ySampling != 1)
                throw std::runtime_error("channel " + exr_names[c] + " is subsampled; a LUT's channels are full resolution");
            if (c == 0) lut.half = ch->type == Imf::HALF;
            else if ((ch->type == Imf::HALF) != lut.half)
                throw std::runtime_error("channel " + exr_names[c] + " is " + (lut.half ? "FLOAT" : "HALF") + " but channel " +
                                         exr_names[0] + " is " + (lut.half ? "HALF" : "FLOAT") +
                                         "; a LUT stores every channel in one type (a damaged or edited header)");
        }
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it)
            if (std::find(exr_names.begin(), exr_names.end(), std::string(it.name())) == exr_names.end())
                throw std::runtime_error("channel " + std::string(it.name()) + " is not named in the metadata's channels");
        // The metadata's encoding (recorded by the writer) must be the texels' type.
        const std::string stored = lut.half ? "float16" : "float32";
        if (lut.metadata.contains("encoding") && lut.metadata.at("encoding") != stored)
            throw std::runtime_error("the metadata says encoding " + lut.metadata.at("encoding").dump() + " but the channels are " +
                                     (lut.half ? "HALF" : "FLOAT"));
        // The typed copies of the axes (for exrheader readers) must agree with the JSON the reader uses.
        for (std::size_t i = 0; i < 3; ++i) {
            const std::string p = std::string("microshadow.axis.") + kAxisNames[i] + ".";
            const auto* lo = header.findTypedAttribute<Imf::DoubleAttribute>(p + "min");
            const auto* hi = header.findTypedAttribute<Imf::DoubleAttribute>(p + "max");
            const auto* n = header.findTypedAttribute<Imf::IntAttribute>(p + "count");
            if ((lo && lo->value() != lut.axes[i].min) || (hi && hi->value() != lut.axes[i].max) ||
                (n && std::int64_t(n->value()) != std::int64_t(lut.axes[i].count)))
                throw std::runtime_error("header attributes " + p + "min/max/count contradict the metadata's axis " + kAxisNames[i]);
        }
        lut.data.assign(std::size_t(lut.width) * lut.height * nc, 0.0f);
        Imf::FrameBuffer fb;
        const std::size_t stride = nc * sizeof(float);
        // Data window may not start at (0, 0): offset the base pointer as OpenEXR expects.
        char* base = exr::frame_base(lut.data.data(), dw.min.x, dw.min.y, stride, stride * lut.width);
        for (std::size_t c = 0; c < nc; ++c)
            fb.insert(exr_names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), stride, stride * lut.width));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        check_lut_texels(lut);
    } catch (const WrongFileKind& e) {
        throw WrongFileKind(path + ": " + e.what());
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error("cannot read LUT " + path + ": bad metadata: " + e.what());
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read LUT " + path + ": " + e.what());
    }
    return lut;
}

std::string lut_channel_label(const LutFile& lut, std::size_t c) {
    const auto& channels = lut.metadata.is_object() ? lut.metadata.value("channels", nlohmann::json::array()) : nlohmann::json::array();
    if (c < channels.size() && channels[c].is_object() && channels[c].contains("exr_channel") && channels[c]["exr_channel"].is_string())
        return channels[c]["exr_channel"].get<std::string>();
    return c < lut.channels.size() ? lut.channels[c].name : std::to_string(c);
}

}  // namespace ms
