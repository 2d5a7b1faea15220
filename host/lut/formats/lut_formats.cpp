#include "lut/formats/lut_formats.hpp"

#include <stdexcept>
#include <string>
#include <vector>

#include "lut/formats/c_header.hpp"
#include "lut/formats/dds.hpp"
#include "lut/formats/ktx2.hpp"
#include "lut/formats/png_atlas.hpp"
#include "lut/formats/texture_writer.hpp"

namespace ms::lutfmt {

LutFormat parse_lut_format(const std::string& s) { return parse_texture_format(s, TextureUse::lut); }

LutFormat lut_format_for_extension(const std::string& path) { return texture_format_for_path(path, TextureUse::lut); }

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
        out.encoding = format_info(out.format).encodings.front();
    }
    if (!format_supports(out.format, out.encoding)) {
        std::vector<std::string> stored;
        for (PixelEncoding e : format_info(out.format).encodings) stored.push_back(to_string(e));
        std::string hint;
        for (std::size_t i = 0; i < stored.size(); ++i) hint += (i == 0 ? "" : i + 1 == stored.size() ? " or " : ", ") + stored[i];
        throw std::invalid_argument(path + ": the " + to_string(out.format) + " format cannot store " + to_string(out.encoding) +
                                    " (use " + hint + ")");
    }
    return out;
}

void write_lut_output(const std::string& path, const LutFile& lut, const LutOutput& output) {
    check_lut_shape(lut);
    // A partial bake marks its unbaked texels NaN (exr_lut.hpp's coverage record): a unorm texel or a
    // C float literal cannot say NaN, and the file would read back as corrupt.
    const bool float_texels = output.encoding == PixelEncoding::float32 || output.encoding == PixelEncoding::float16;
    const bool binary = format_info(output.format).binary;
    if (is_partial_bake(lut) && !(float_texels && binary))
        throw std::invalid_argument(path + ": a partial bake (unbaked texels are NaN, see \"coverage\" in its metadata) can be "
                                    "written only as .exr, .ktx2 or .dds with float32 or float16, not " + to_string(output.format) +
                                    " " + to_string(output.encoding));
    // The EXR is write_lut's (exr_lut.hpp: its own metadata and header attributes); every format goes
    // through the one texture writer.
    if (output.format == LutFormat::exr) {
        write_lut(path, lut.axes, lut.channels, lut.data, lut.metadata, output.encoding == PixelEncoding::float16);
        return;
    }
    write_texture(path, output.format, lut_texture(path, lut, output), output.encoding);
}

TextureData lut_texture(const std::string& path, const LutFile& lut, const LutOutput& output) {
    switch (output.format) {
        case LutFormat::ktx2: return ktx2_lut_texture(lut, output.encoding);
        case LutFormat::dds: return dds_lut_texture(lut, output.encoding);
        case LutFormat::header: return c_lut_texture(path, lut, output.encoding, false);
        case LutFormat::inc: return c_lut_texture(path, lut, output.encoding, true);
        case LutFormat::png: return png_lut_texture(lut, output.encoding);
        case LutFormat::exr: break;
    }
    throw std::invalid_argument(path + ": a LUT's EXR is written by write_lut");
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
