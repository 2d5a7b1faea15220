#include "lut/formats/lut_reader.hpp"

#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <png.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>

#include "io/bounded_json.hpp"
#include "io/exr_preflight.hpp"
#include "io/input_file.hpp"
#include "io/input_guard.hpp"
#include "io/text.hpp"
#include "lut/formats/texture_reader.hpp"

namespace ms::lutfmt {

namespace {

// The most texels x channels a LUT may hold (exr_lut.cpp's limit): a 256^3 atlas of 4 channels.
constexpr std::uint64_t kMaxLutValues = std::uint64_t(1) << 26, kMaxLutTexels = kMaxLutValues / 4;
// A C header spells each component in at most ~16 characters ("0.123456791f, "): the largest text LUT.
constexpr std::uint64_t kMaxTextBytes = kMaxLutValues * 16 + (std::uint64_t(16) << 20);

const char kTextOpening[] = "/* microshadow LUT";

std::string first_bytes(const std::string& path, std::size_t n) {
    require_regular_file(path, "LUT");  // a FIFO would block open() beyond the reach of signals
    note_input(path);
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw std::runtime_error(path + ": cannot open for reading (" + std::strerror(errno) + ")");
    std::string head(n, '\0');
    head.resize(std::fread(head.data(), 1, n, f));
    std::fclose(f);
    return head;
}

bool begins(const std::string& s, const unsigned char* magic, std::size_t n) {
    return s.size() >= n && std::memcmp(s.data(), magic, n) == 0;
}

// Every format stores 4 components a texel; the metadata says how many are data, and the writer fills
// the rest with the last data channel (lut_formats.hpp). A component that differs from it is data the
// metadata does not name (metadata naming 3 channels over RGBA data would drop A): refused, not dropped.
// component(i, c): component c of texel i as stored.
template <class Component>
void check_padding(std::size_t texels, std::size_t data_channels, const Component& component) {
    for (std::size_t i = 0; i < texels; ++i)
        for (std::size_t c = data_channels; c < 4; ++c) {
            const auto last = component(i, data_channels - 1), pad = component(i, c);
            if (!(pad == last) && !(pad != pad && last != last))  // equal, or both NaN (unbaked texels)
                throw std::runtime_error("component " + std::to_string(c) + " of texel " + std::to_string(i) + " holds " +
                                         format_g(double(pad), 9) + ", not the padding (a copy of component " +
                                         std::to_string(data_channels - 1) + ", " + format_g(double(last), 9) +
                                         "): the metadata names " + std::to_string(data_channels) +
                                         " channel(s) but the file holds more data (metadata of another file?)");
        }
}

// --- texture files (KTX2, DDS): one 2D or 3D level of RGBA, the LUT's atlas with NdotV along z -------

LutFile lut_from_texture(TextureFile f, const char* container) {
    const TextureData& t = f.texture;
    if (t.metadata.empty()) {
        // A DDS has no room for metadata: without its sidecar there are no axes to read it by.
        if (std::string(container) == "dds")
            throw std::runtime_error("no metadata sidecar " + std::string("<file>.json") +
                                     " beside the DDS (the bake writes it with the file; copy both)");
        throw WrongFileKind("no \"microshadow\" metadata in the key/value data: not a microshadow LUT");
    }
    LutFile lut = lut_from_metadata(t.metadata);
    if (t.faces != 1 || t.levels.size() != 1)
        throw std::runtime_error(std::string("a ") + container + " LUT is one face and one mip level, not " + std::to_string(t.faces) +
                                 " faces and " + std::to_string(t.levels.size()) + " levels");
    if (t.width != lut.visibility().count || t.height != lut.n_dot_l().count || t.depth != lut.n_dot_v().count)
        throw std::runtime_error("the texture is " + std::to_string(t.width) + " x " + std::to_string(t.height) + " x " +
                                 std::to_string(t.depth) + " texels; the axes say " + std::to_string(lut.visibility().count) +
                                 " x " + std::to_string(lut.n_dot_l().count) + " x " + std::to_string(lut.n_dot_v().count));
    // x = visibility, y = NdotL, z = NdotV: texel (x, y, z) is the atlas's (x, z * nNdotL + y), so the
    // level is the atlas row by row already; only the RGBA padding goes.
    const std::size_t nc = lut.channels.size(), texels = std::size_t(lut.width) * lut.height;
    check_padding(texels, nc, [&](std::size_t i, std::size_t c) { return t.levels[0][i * 4 + c]; });
    lut.data.resize(texels * nc);
    for (std::size_t i = 0; i < texels; ++i)
        for (std::size_t c = 0; c < nc; ++c) lut.data[i * nc + c] = t.levels[0][i * 4 + c];
    lut.half = f.encoding == PixelEncoding::float16;
    return lut;
}

// --- PNG atlas ------------------------------------------------------------------------------------

struct PngPixels {
    std::uint32_t width = 0, height = 0;
    int bits = 0;
    std::vector<std::uint8_t> rows;  // width * 4 * bits / 8 bytes a row, samples big-endian
    std::string text;                // the "microshadow" iTXt/tEXt chunk ("" when none)
    char error[256] = {};
};

void png_error_handler(png_structp png, png_const_charp message) {
    auto* out = static_cast<PngPixels*>(png_get_error_ptr(png));
    std::snprintf(out->error, sizeof out->error, "%s", message);
    png_longjmp(png, 1);
}
void png_warning_handler(png_structp, png_const_charp) {}

void copy_text(png_structp png, png_infop info, PngPixels& out) {
    png_textp text = nullptr;
    int count = 0;
    png_get_text(png, info, &text, &count);
    for (int i = 0; i < count; ++i)
        if (std::strcmp(text[i].key, "microshadow") == 0)
            out.text.assign(text[i].text, text[i].compression >= PNG_ITXT_COMPRESSION_NONE ? text[i].itxt_length : text[i].text_length);
}

// libpng reports errors by longjmp: this function holds no object with a destructor (everything it
// fills lives in the caller's `out`), so the jump skips nothing that must be destroyed.
bool decode_png(std::FILE* f, PngPixels& out) {
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &out, png_error_handler, png_warning_handler);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    png_infop end = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info || !end) {
        png_destroy_read_struct(&png, &info, &end);
        std::snprintf(out.error, sizeof out.error, "libpng: out of memory");
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, &end);
        return false;
    }
    png_init_io(png, f);
    png_read_info(png, info);
    png_uint_32 w = 0, h = 0;
    int depth = 0, colour = 0, interlace = 0;
    png_get_IHDR(png, info, &w, &h, &depth, &colour, &interlace, nullptr, nullptr);
    if (colour != PNG_COLOR_TYPE_RGB_ALPHA || (depth != 8 && depth != 16) || interlace != PNG_INTERLACE_NONE) {
        std::snprintf(out.error, sizeof out.error, "a %d-bit PNG of colour type %d: a LUT atlas is 8- or 16-bit RGBA, not interlaced", depth, colour);
        png_destroy_read_struct(&png, &info, &end);
        return false;
    }
    // Bounded before the rows are allocated: a 50-byte header may claim 2^31 x 2^31 pixels.
    if (std::uint64_t(w) * h > kMaxLutTexels) {
        std::snprintf(out.error, sizeof out.error, "%u x %u pixels is more than the limit of %llu", unsigned(w), unsigned(h),
                      static_cast<unsigned long long>(kMaxLutTexels));
        png_destroy_read_struct(&png, &info, &end);
        return false;
    }
    out.width = w, out.height = h, out.bits = depth;
    const std::size_t row_bytes = std::size_t(w) * 4 * (depth / 8);
    out.rows.resize(row_bytes * h);
    for (png_uint_32 y = 0; y < h; ++y) png_read_row(png, out.rows.data() + y * row_bytes, nullptr);
    png_read_end(png, end);
    copy_text(png, info, out);
    if (out.text.empty()) copy_text(png, end, out);
    png_destroy_read_struct(&png, &info, &end);
    return true;
}

LutFile read_png_lut(const std::string& path, PixelEncoding& encoding) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw std::runtime_error("cannot open for reading (" + std::string(std::strerror(errno)) + ")");
    PngPixels px;
    const bool ok = decode_png(f, px);
    std::fclose(f);
    if (!ok) throw std::runtime_error(std::string("not a readable PNG LUT atlas: ") + px.error);
    if (px.text.empty()) throw WrongFileKind("no \"microshadow\" text chunk: not a microshadow LUT atlas");
    const nlohmann::json meta = parse_bounded_json(px.text, "the \"microshadow\" text chunk");
    LutFile lut = lut_from_metadata(meta);
    if (px.width != lut.width || px.height != lut.height)
        throw std::runtime_error("the image is " + std::to_string(px.width) + " x " + std::to_string(px.height) +
                                 " pixels; the axes say " + std::to_string(lut.width) + " x " + std::to_string(lut.height));
    encoding = px.bits == 8 ? PixelEncoding::unorm8 : PixelEncoding::unorm16;
    const double scale = px.bits == 8 ? 255.0 : 65535.0;
    const std::size_t nc = lut.channels.size(), texels = std::size_t(lut.width) * lut.height;
    check_padding(texels, nc, [&](std::size_t i, std::size_t c) {
        const std::size_t s = i * 4 + c;
        return px.bits == 8 ? unsigned(px.rows[s]) : unsigned(px.rows[2 * s]) << 8 | px.rows[2 * s + 1];
    });
    lut.data.resize(texels * nc);
    for (std::size_t i = 0; i < texels; ++i)
        for (std::size_t c = 0; c < nc; ++c) {
            const std::size_t s = i * 4 + c;
            const unsigned q = px.bits == 8 ? px.rows[s] : unsigned(px.rows[2 * s]) << 8 | px.rows[2 * s + 1];
            lut.data[i * nc + c] = float(q / scale);
        }
    return lut;
}

// --- C header and .inc --------------------------------------------------------------------------

// The C string literals from `at` up to the ';' that ends the declaration, concatenated and unescaped
// (the writer escapes '"', '\\' and control bytes as octal: c_header.cpp's c_string).
std::string c_string_value(const std::string& text, std::size_t at, std::size_t* end) {
    std::string out;
    while (at < text.size() && text[at] != ';') {
        if (text[at] != '"') {
            ++at;
            continue;
        }
        for (++at; at < text.size() && text[at] != '"'; ++at) {
            if (text[at] != '\\') {
                out += text[at];
                continue;
            }
            if (++at >= text.size()) break;
            if (text[at] >= '0' && text[at] <= '7') {
                int v = 0, digits = 0;
                while (digits < 3 && at < text.size() && text[at] >= '0' && text[at] <= '7') v = v * 8 + (text[at++] - '0'), ++digits;
                out += char(v);
                --at;
            } else {
                out += text[at];
            }
        }
        ++at;  // the closing quote
    }
    if (at >= text.size()) throw std::runtime_error("the metadata string is not terminated");
    *end = at;
    return out;
}

// The comma-separated components in text[begin, end), comments skipped, as floats in `encoding`.
std::vector<float> c_values(const std::string& text, std::size_t begin, std::size_t end, PixelEncoding encoding) {
    std::vector<float> out;
    std::size_t at = begin;
    while (at < end) {
        const char ch = text[at];
        if (ch == '/' && at + 1 < end && text[at + 1] == '*') {
            const std::size_t close = text.find("*/", at + 2);
            if (close == std::string::npos || close >= end) throw std::runtime_error("an unterminated comment among the values");
            at = close + 2;
            continue;
        }
        if (ch == ',' || std::isspace(static_cast<unsigned char>(ch))) {
            ++at;
            continue;
        }
        const char* first = text.c_str() + at;
        char* stop = nullptr;
        errno = 0;
        float v = 0;
        if (encoding == PixelEncoding::float32) {
            v = std::strtof(first, &stop);
            if (stop != first && *stop == 'f') ++stop;  // the float suffix
        } else {
            const unsigned long q = std::strtoul(first, &stop, encoding == PixelEncoding::float16 ? 16 : 10);
            const unsigned long top = encoding == PixelEncoding::unorm8 ? 255ul : 65535ul;
            if (stop != first && q > top) throw std::runtime_error("value " + std::string(first, std::size_t(stop - first)) + " is outside the " + to_string(encoding) + " range");
            v = encoding == PixelEncoding::float16 ? half_to_float(std::uint16_t(q)) : float(double(q) / double(top));
        }
        if (stop == first || errno == ERANGE || (stop < text.c_str() + end && *stop != ',' && !std::isspace(static_cast<unsigned char>(*stop))))
            throw std::runtime_error("value " + std::to_string(out.size()) + " ('" + text.substr(at, 16) + "') is not a " + to_string(encoding) + " component");
        out.push_back(v);
        at = std::size_t(stop - text.c_str());
    }
    return out;
}

// A C header's #defines and the declared type of its data array repeat what the metadata string says,
// for a compiler; a program uses them, not the JSON, so they must say the same (a header whose defines
// were edited would size or sample the texture wrongly in the renderer and pass here).
void check_header_defines(const std::string& text, std::size_t metadata_at, const LutFile& lut, PixelEncoding encoding) {
    // The identifier before "_metadata[] =": "static const char <id>_metadata[] =".
    std::size_t id_begin = metadata_at;
    while (id_begin > 0 && (std::isalnum(static_cast<unsigned char>(text[id_begin - 1])) || text[id_begin - 1] == '_')) --id_begin;
    const std::string id = text.substr(id_begin, metadata_at - id_begin), ID = to_upper(id);
    if (id.empty()) throw std::runtime_error("no identifier before _metadata[]");
    std::map<std::string, std::string> defines;
    for (std::size_t at = text.find("#define "); at != std::string::npos; at = text.find("#define ", at + 1)) {
        if (at > 0 && text[at - 1] != '\n') continue;
        std::istringstream line(text.substr(at + 8, text.find('\n', at) - at - 8));
        std::string name, value;
        line >> name >> value;
        if (name.compare(0, ID.size() + 1, ID + "_") == 0) defines[name.substr(ID.size() + 1)] = value;
    }
    const auto check = [&](const std::string& key, const std::string& want, bool required) {
        const auto it = defines.find(key);
        if (it == defines.end()) {
            if (required) throw std::runtime_error("#define " + ID + "_" + key + " is missing (the metadata says " + want + ")");
            return;
        }
        std::string got = it->second;
        if (!got.empty() && (got.back() == 'u' || got.back() == 'U')) got.pop_back();
        bool same = got == want;
        if (!same) {  // numbers: the same value in another spelling
            char* end = nullptr;
            const double g = std::strtod(got.c_str(), &end);
            same = end && *end == '\0' && !got.empty() && g == std::strtod(want.c_str(), nullptr);
        }
        if (!same)
            throw std::runtime_error("#define " + ID + "_" + key + " " + it->second + " contradicts the metadata (" + want +
                                     "): the header's defines and its data disagree");
    };
    const auto number = [](double v) {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%.17g", v);
        return std::string(buf);
    };
    check("WIDTH", std::to_string(lut.visibility().count), true);
    check("HEIGHT", std::to_string(lut.n_dot_l().count), true);
    check("DEPTH", std::to_string(lut.n_dot_v().count), true);
    check("COMPONENTS", "4", true);
    check("ROUGHNESS_CHANNELS", std::to_string(lut.channels.size()), true);
    const char* axis_ids[3] = {"VISIBILITY", "N_DOT_L", "N_DOT_V"};
    for (std::size_t i = 0; i < 3; ++i) {
        check(std::string(axis_ids[i]) + "_MIN", number(lut.axes[i].min), false);
        check(std::string(axis_ids[i]) + "_MAX", number(lut.axes[i].max), false);
        check(std::string(axis_ids[i]) + "_TEXEL_CENTRES", lut.axes[i].texel == TexelConvention::centres ? "1" : "0", false);
    }
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < lut.channels.size(); ++c) check(std::string("ROUGHNESS_") + names[c], number(lut.channels[c].roughness), false);
    if (lut.metadata.contains("ao_weighting") && lut.metadata.at("ao_weighting").is_string())
        check("COSINE_AO", lut.metadata.at("ao_weighting") == "cosine" ? "1" : "0", false);
    // The array's element type.
    const std::string data_decl = id + "_data[";
    const std::size_t d = text.find(data_decl);
    const std::size_t line_start = d == std::string::npos ? d : text.rfind('\n', d);
    if (d != std::string::npos) {
        const std::string decl = text.substr(line_start == std::string::npos ? 0 : line_start + 1, d - (line_start == std::string::npos ? 0 : line_start + 1));
        const std::string want = encoding == PixelEncoding::float32 ? "float" : encoding == PixelEncoding::unorm8 ? "uint8_t" : "uint16_t";
        if (decl.find(" " + want + " ") == std::string::npos)
            throw std::runtime_error("the data array is declared '" + decl + "', not " + want + " for the metadata's encoding " + to_string(encoding));
    }
}

LutFile read_text_lut(const std::string& path, LutFormat format, PixelEncoding& encoding) {
    const std::string text = read_input_file(path, kMaxTextBytes, "LUT source file");
    nlohmann::json meta;
    std::size_t values_begin = 0, values_end = text.size();
    if (format == LutFormat::header) {
        const std::size_t m = text.find("_metadata[] =");
        if (m == std::string::npos) throw std::runtime_error("no <prefix>_metadata[] string");
        std::size_t literal_end = 0;
        meta = parse_bounded_json(c_string_value(text, m, &literal_end), "the <prefix>_metadata[] string");
        const std::size_t d = text.find("_data[", literal_end);
        const std::size_t open = d == std::string::npos ? d : text.find('{', d);
        const std::size_t close = open == std::string::npos ? open : text.find('}', open);
        if (close == std::string::npos) throw std::runtime_error("no <prefix>_data[] = { ... } array");
        values_begin = open + 1, values_end = close;
    } else {
        const std::string key = "/* microshadow-metadata: ";
        const std::size_t m = text.find(key);
        if (m == std::string::npos)
            throw std::runtime_error("no \"" + key + "...\" line: an .inc written before the metadata was recorded; "
                                     "export it again from the bake's OpenEXR");
        const std::size_t close = text.find(" */", m);
        if (close == std::string::npos) throw std::runtime_error("the metadata comment is not closed");
        meta = parse_bounded_json(text.substr(m + key.size(), close - m - key.size()), "the metadata comment");
        values_begin = close + 3;
    }
    if (meta.is_discarded() || !meta.is_object()) throw std::runtime_error("the recorded metadata is not a JSON object");
    LutFile lut = lut_from_metadata(meta);
    if (!meta.contains("encoding") || !meta.at("encoding").is_string())
        throw std::runtime_error("the metadata has no \"encoding\" (float32, float16, unorm8 or unorm16)");
    encoding = parse_pixel_encoding(meta.at("encoding").get<std::string>());
    if (format == LutFormat::header) check_header_defines(text, text.find("_metadata[] ="), lut, encoding);
    const std::vector<float> rgba = c_values(text, values_begin, values_end, encoding);
    const std::size_t nc = lut.channels.size(), texels = std::size_t(lut.width) * lut.height;
    if (rgba.size() != texels * 4)
        throw std::runtime_error(std::to_string(rgba.size()) + " values; the axes need " + std::to_string(texels) + " texels x 4 components");
    check_padding(texels, nc, [&](std::size_t i, std::size_t c) { return rgba[i * 4 + c]; });
    lut.data.resize(texels * nc);
    for (std::size_t i = 0; i < texels; ++i)
        for (std::size_t c = 0; c < nc; ++c) lut.data[i * nc + c] = rgba[i * 4 + c];
    lut.half = encoding == PixelEncoding::float16;
    return lut;
}

// --- format detection ---------------------------------------------------------------------------

const unsigned char kExrMagic[4] = {0x76, 0x2f, 0x31, 0x01};
const unsigned char kKtx2Magic[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
const unsigned char kDdsMagic[4] = {'D', 'D', 'S', ' '};
const unsigned char kPngMagic[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};

}  // namespace

LutFormat detect_lut_format(const std::string& path) {
    const std::string head = first_bytes(path, 64);
    if (begins(head, kExrMagic, 4)) return LutFormat::exr;
    if (begins(head, kKtx2Magic, 12)) return LutFormat::ktx2;
    if (begins(head, kDdsMagic, 4)) return LutFormat::dds;
    if (begins(head, kPngMagic, 8)) return LutFormat::png;
    if (head.compare(0, sizeof kTextOpening - 1, kTextOpening) == 0) {
        // The header declares its metadata string; the .inc holds only values (and comments).
        const std::string text = read_input_file(path, kMaxTextBytes, "LUT source file");
        return text.find("_metadata[] =") != std::string::npos ? LutFormat::header : LutFormat::inc;
    }
    // No known opening: a damaged file of a known kind gets its own reader's message ("not a readable
    // OpenEXR file: ..."), anything else one naming the formats.
    try {
        const LutFormat by_name = lut_format_for_extension(path);
        if (by_name != LutFormat::header && by_name != LutFormat::inc) return by_name;
    } catch (const std::invalid_argument&) {
    }
    throw WrongFileKind(path + ": not a LUT file this tool writes (OpenEXR, KTX2, DDS, C header, .inc or PNG atlas)");
}

nlohmann::json read_file_metadata(const std::string& path) {
    try {
        switch (detect_lut_format(path)) {
            case LutFormat::exr: {
                exr::preflight_image(path, kMaxLutValues);
                Imf::InputFile file(path.c_str());
                const auto* attr = file.header().findTypedAttribute<Imf::StringAttribute>("microshadow");
                if (!attr) return nullptr;
                const nlohmann::json j = parse_bounded_json(attr->value(), "the \"microshadow\" attribute");
                return j.is_object() ? j : nlohmann::json();
            }
            case LutFormat::ktx2: return read_ktx2_metadata(path);
            case LutFormat::dds: return read_dds_metadata(path);
            case LutFormat::png: {
                std::FILE* f = std::fopen(path.c_str(), "rb");
                if (!f) return nullptr;
                PngPixels px;
                const bool ok = decode_png(f, px);
                std::fclose(f);
                if (!ok) throw std::runtime_error(px.error);
                if (px.text.empty()) return nullptr;
                const nlohmann::json j = parse_bounded_json(px.text, "the \"microshadow\" text chunk");
                return j.is_object() ? j : nlohmann::json();
            }
            case LutFormat::header:
            case LutFormat::inc: {
                PixelEncoding e;
                return read_text_lut(path, detect_lut_format(path), e).metadata;
            }
        }
    } catch (const WrongFileKind&) {
        return nullptr;
    } catch (const std::exception& e) {
        const std::string what = e.what();
        throw std::runtime_error(what.find(path) == std::string::npos ? path + ": " + what : what);
    }
    return nullptr;
}

LutFile read_lut_file(const std::string& path, LutFileInfo* info) {
    LutFileInfo found;
    LutFile lut;
    try {
        found.format = detect_lut_format(path);
        switch (found.format) {
            case LutFormat::exr:
                lut = read_exr_lut(path);  // names the file itself
                found.encoding = lut.half ? PixelEncoding::float16 : PixelEncoding::float32;
                if (info) *info = found;
                return lut;
            case LutFormat::ktx2: {
                TextureFile t = read_ktx2_texture(path, kMaxLutTexels);
                found.encoding = t.encoding;
                lut = lut_from_texture(std::move(t), "ktx2");
                break;
            }
            case LutFormat::dds: {
                TextureFile t = read_dds_texture(path, kMaxLutTexels);
                found.encoding = t.encoding;
                lut = lut_from_texture(std::move(t), "dds");
                break;
            }
            case LutFormat::png: lut = read_png_lut(path, found.encoding); break;
            case LutFormat::header:
            case LutFormat::inc: lut = read_text_lut(path, found.format, found.encoding); break;
        }
        // The metadata's encoding must be the one the texels are stored in: a mismatch means the
        // metadata (a DDS's sidecar, say) belongs to another file.
        if (lut.metadata.contains("encoding") && lut.metadata.at("encoding") != to_string(found.encoding))
            throw std::runtime_error("the metadata says encoding " + lut.metadata.at("encoding").dump() + " but the texels are " +
                                     to_string(found.encoding) + " (metadata of another file?)");
        check_lut_texels(lut);
    } catch (const WrongFileKind& e) {
        const std::string what = e.what();
        throw WrongFileKind(what.find(path) == std::string::npos ? path + ": " + what : what);
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error("cannot read LUT " + path + ": bad metadata: " + e.what());
    } catch (const std::exception& e) {
        const std::string what = e.what();
        throw std::runtime_error(what.find(path) == std::string::npos ? "cannot read LUT " + path + ": " + what : what);
    }
    if (info) *info = found;
    return lut;
}

LutFile lut_for_export(LutFile lut, const LutFileInfo& from, const std::string& source) {
    nlohmann::json& meta = lut.metadata;
    double earlier = 0;
    if (meta.contains("error_budget") && meta.at("error_budget").is_object()) {
        const auto& b = meta.at("error_budget");
        for (const char* key : {"quantisation", "earlier_quantisation"})
            if (b.contains(key) && b.at(key).is_number()) earlier += b.at(key).get<double>();
    }
    for (const char* key : {"file_format", "encoding", "error_budget", "max_total_error", "texture_channels", "padded_channels",
                            "padding", "ktx2_orientation", "dds_dxgi_format", "earlier_quantisation_error"})
        meta.erase(key);
    if (earlier > 0) meta["earlier_quantisation_error"] = earlier;
    meta["exported_from"] = {{"file", source}, {"format", to_string(from.format)}, {"encoding", to_string(from.encoding)}};
    return lut;
}

double encoding_step_bound(PixelEncoding encoding) {
    switch (encoding) {
        case PixelEncoding::float32: return 0.0;
        case PixelEncoding::float16: return std::ldexp(1.0, -12);
        case PixelEncoding::unorm8: return 0.5 / 255.0;
        case PixelEncoding::unorm16: return 0.5 / 65535.0;
    }
    return 0.0;
}

}  // namespace ms::lutfmt

namespace ms {

LutFile read_lut(const std::string& path) { return lutfmt::read_lut_file(path); }

}  // namespace ms
