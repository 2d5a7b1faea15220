#include "lut/formats/lut_formats.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>

#include "lut/formats/c_header.hpp"
#include "lut/formats/dds.hpp"
#include "lut/formats/ktx2.hpp"
#include "lut/formats/png_atlas.hpp"

namespace ms::lutfmt {

std::string to_string(LutFormat f) {
    switch (f) {
        case LutFormat::exr: return "exr";
        case LutFormat::ktx2: return "ktx2";
        case LutFormat::dds: return "dds";
        case LutFormat::header: return "header";
        case LutFormat::inc: return "inc";
        case LutFormat::png: return "png";
    }
    return "?";
}

LutFormat parse_lut_format(const std::string& s) {
    for (LutFormat f : {LutFormat::exr, LutFormat::ktx2, LutFormat::dds, LutFormat::header, LutFormat::inc, LutFormat::png})
        if (s == to_string(f)) return f;
    throw std::invalid_argument("--format must be exr, ktx2, dds, header, inc or png, not '" + s + "'");
}

namespace {

bool extension_is(const std::string& ext, std::initializer_list<const char*> names) {
    return std::any_of(names.begin(), names.end(), [&](const char* n) { return ext == n; });
}

}  // namespace

LutFormat lut_format_for_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (ext == ".exr") return LutFormat::exr;
    if (ext == ".ktx2") return LutFormat::ktx2;
    if (ext == ".dds") return LutFormat::dds;
    if (extension_is(ext, {".h", ".hpp", ".hh"})) return LutFormat::header;
    if (ext == ".inc") return LutFormat::inc;
    if (ext == ".png") return LutFormat::png;
    throw std::invalid_argument(path + ": unknown LUT file extension '" + ext +
                                "' (use .exr, .ktx2, .dds, .h, .hpp, .inc or .png)");
}

namespace {

bool supports(LutFormat f, PixelEncoding e) {
    if (f == LutFormat::exr) return e == PixelEncoding::float32 || e == PixelEncoding::float16;
    if (f == LutFormat::png) return e == PixelEncoding::unorm8 || e == PixelEncoding::unorm16;
    return true;
}

}  // namespace

LutOutput resolve_lut_output(const std::string& path, const std::string& format, const std::string& encoding, bool half) {
    LutOutput out;
    out.format = lut_format_for_extension(path);
    if (!format.empty() && parse_lut_format(format) != out.format)
        throw std::invalid_argument(path + ": --format " + format + " does not match the file extension (which means " +
                                    to_string(out.format) + ")");
    if (!encoding.empty()) {
        out.encoding = parse_pixel_encoding(encoding);
        if (half && out.encoding != PixelEncoding::float16)
            throw std::invalid_argument("--half means --encoding float16; it contradicts --encoding " + encoding);
    } else if (half) {
        out.encoding = PixelEncoding::float16;
    } else {
        out.encoding = out.format == LutFormat::png ? PixelEncoding::unorm8 : PixelEncoding::float32;
    }
    if (!supports(out.format, out.encoding))
        throw std::invalid_argument(path + ": the " + to_string(out.format) + " format cannot store " +
                                    to_string(out.encoding) + (out.format == LutFormat::png ? " (use unorm8 or unorm16)" : " (use float32 or float16)"));
    return out;
}

void write_lut_output(const std::string& path, const LutFile& lut, const LutOutput& output) {
    check_lut_shape(lut);
    // A partial bake marks its unbaked texels NaN (exr_lut.hpp's coverage record): a unorm texel or a
    // C float literal cannot say NaN, and the file would read back as corrupt.
    const bool float_texels = output.encoding == PixelEncoding::float32 || output.encoding == PixelEncoding::float16;
    const bool binary = output.format == LutFormat::exr || output.format == LutFormat::ktx2 || output.format == LutFormat::dds;
    if (is_partial_bake(lut) && !(float_texels && binary))
        throw std::invalid_argument(path + ": a partial bake (unbaked texels are NaN, see \"coverage\" in its metadata) can be "
                                    "written only as .exr, .ktx2 or .dds with float32 or float16, not " + to_string(output.format) +
                                    " " + to_string(output.encoding));
    switch (output.format) {
        case LutFormat::exr:
            write_lut(path, lut.axes, lut.channels, lut.data, lut.metadata, output.encoding == PixelEncoding::float16);
            return;
        case LutFormat::ktx2: write_ktx2(path, lut, output.encoding); return;
        case LutFormat::dds: write_dds(path, lut, output.encoding); return;
        case LutFormat::header: write_c_header(path, lut, output.encoding, false); return;
        case LutFormat::inc: write_c_header(path, lut, output.encoding, true); return;
        case LutFormat::png: write_png_atlas(path, lut, output.encoding); return;
    }
}

LutFile make_lut_file(const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels, std::vector<float> data,
                      nlohmann::json metadata) {
    LutFile lut;
    lut.axes = axes;
    lut.channels = channels;
    lut.metadata = std::move(metadata);
    // Every format's metadata records the domain (as write_lut does for the EXR).
    if (lut.metadata.is_object() && !lut.metadata.contains("domain"))
        lut.metadata["domain"] = lut_domain(axes, channels).to_json("the lookups this LUT was baked for; outside, clamp-to-edge answers");
    if (axes.size() == 3) {
        lut.width = axes[0].count;
        lut.height = axes[1].count * axes[2].count;
    }
    lut.data = std::move(data);
    check_lut_shape(lut);
    return lut;
}

}  // namespace ms::lutfmt
