#include "lut/formats/texture_writer.hpp"

#include <ImfHeader.h>
#include <ImfIntAttribute.h>
#include <ImfStringAttribute.h>
#include <ImfDoubleAttribute.h>

#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "io/exr_file.hpp"
#include "io/png_file.hpp"
#include "io/text.hpp"

namespace ms::lutfmt {

TextureFiles add_texture_files(OutputSet& outputs, const std::string& path, TextureFormat format) {
    TextureFiles files;
    files.format = format;
    files.file = outputs.add(path, format_info(format).binary);
    if (format_info(format).sidecar) files.sidecar = outputs.add(path + ".json");
    return files;
}

namespace {

// The single image the EXR, PNG and C formats store: level 0 of one face.
void check_single_image(const TextureData& t, TextureFormat format) {
    check_texture(t);
    if (t.faces != 1 || t.levels.size() != 1)
        throw std::invalid_argument("the " + to_string(format) + " format holds one image: no cubemap faces or mip levels");
}

// The OpenEXR header and channel names of `t` (texture_writer.hpp).
Imf::Header exr_header(const TextureData& t, bool half, std::vector<std::string>& names) {
    check_single_image(t, TextureFormat::exr);
    names = t.channel_names;
    if (names.empty())
        for (std::uint32_t c = 0; c < t.channels; ++c) names.push_back(std::string(1, "RGBA"[c]));
    // Names for the first channels of each texel (a texture padded to RGBA may name only its data).
    if (names.empty() || names.size() > t.channels) throw std::invalid_argument("texture: 1 to `channels` EXR channel names");
    Imf::Header header = exr::image_header(t.width, t.height * t.depth, names, half);
    if (t.exr_typed_metadata) exr::insert_metadata(header, t.metadata);
    else header.insert("microshadow", Imf::StringAttribute(t.metadata.dump()));
    for (const auto& [name, value] : t.exr_attributes) {
        if (const int* i = std::get_if<int>(&value)) header.insert(name, Imf::IntAttribute(*i));
        else if (const double* d = std::get_if<double>(&value)) header.insert(name, Imf::DoubleAttribute(*d));
        else header.insert(name, Imf::StringAttribute(std::get<std::string>(value)));
    }
    return header;
}

void write_png_image(OutputSet& outputs, const TextureFiles& files, const TextureData& t, PixelEncoding encoding) {
    const unsigned bits = encoding == PixelEncoding::unorm8 ? 8 : 16;
    const std::uint32_t png_channels = t.channels == 4 ? 4 : 3;
    const std::size_t texels = std::size_t(t.width) * t.height * t.depth;
    const std::vector<float>& data = t.levels[0];
    std::vector<std::uint8_t> pixels(texels * png_channels * (bits / 8), 0);
    for (std::size_t i = 0; i < texels; ++i)
        for (std::uint32_t c = 0; c < t.channels; ++c) {
            const std::uint32_t q = to_unorm(data[i * t.channels + c], bits);
            const std::size_t at = i * png_channels + c;
            if (bits == 8) pixels[at] = std::uint8_t(q);
            else pixels[2 * at] = std::uint8_t(q >> 8), pixels[2 * at + 1] = std::uint8_t(q & 0xff);  // PNG samples are big-endian
        }
    PngImage png;
    png.width = t.width;
    png.height = t.height * t.depth;
    png.channels = int(png_channels);
    png.bits = int(bits);
    png.pixels = pixels.data();
    png.linear_data = true;  // data, not sRGB colour
    write_png(outputs.temp_path(files.file), png, "microshadow", t.metadata.dump());
}

// A C string literal of `s` (quotes, backslashes and control bytes escaped; split every 120 bytes so
// no line is huge).
std::string c_string(const std::string& s) {
    std::string out = "\"";
    std::size_t run = 0;
    for (unsigned char c : s) {
        if (c == '"' || c == '\\') out += '\\', out += char(c);
        else if (c < 0x20 || c >= 0x7f) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\%03o", c);  // octal: a hex escape would swallow following hex digits
            out += buf;
        } else out += char(c);
        if (++run % 120 == 0) out += "\"\n    \"";
    }
    return out + "\"";
}

std::string c_values(const TextureData& t, PixelEncoding encoding) {
    const std::vector<float>& data = t.levels[0];
    std::ostringstream out;
    const std::size_t per_line = encoding == PixelEncoding::float32 ? 4 : 8;
    for (std::size_t i = 0; i < data.size(); ++i) {
        if (i % per_line == 0) out << "    ";
        switch (encoding) {
            case PixelEncoding::float32: out << c_float_literal(data[i]); break;
            case PixelEncoding::float16: {
                char buf[12];
                std::snprintf(buf, sizeof buf, "0x%04x", unsigned(float_to_half(data[i])));
                out << buf;
                break;
            }
            case PixelEncoding::unorm8: out << to_unorm(data[i], 8); break;
            case PixelEncoding::unorm16: out << to_unorm(data[i], 16); break;
        }
        out << (i + 1 == data.size() ? "\n" : (i % per_line == per_line - 1 ? ",\n" : ", "));
    }
    return out.str();
}

const char* c_type(PixelEncoding e) {
    return e == PixelEncoding::float32 ? "float" : e == PixelEncoding::unorm8 ? "uint8_t" : "uint16_t";
}

}  // namespace

std::string c_float_literal(float v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", double(v));
    std::string s = buf;
    if (s.find_first_of(".eE") == std::string::npos) s += ".0";
    return s + "f";
}

std::string c_source(const TextureData& t, PixelEncoding encoding, bool inc_only) {
    check_single_image(t, inc_only ? TextureFormat::inc : TextureFormat::header);
    if (t.c_identifier.empty()) throw std::invalid_argument("texture: a C source needs an identifier");
    std::ostringstream o;
    for (std::size_t i = 0; i < t.c_comment.size(); ++i) o << (i == 0 ? "/* " : " * ") << t.c_comment[i] << "\n";
    o << (t.c_comment.empty() ? "" : " */\n");
    if (inc_only) {
        // The whole metadata on one line, so that the values can be read back (lut_reader.hpp).
        // '/' is written "\/" (the same string to a JSON parser): no "*/" can end the comment early.
        std::string json;
        for (char ch : t.metadata.dump()) json += ch == '/' ? std::string("\\/") : std::string(1, ch);
        o << "/* microshadow-metadata: " << json << " */\n";
        o << "/* " << c_type(encoding) << " values; #include inside an initialiser */\n" << c_values(t, encoding);
        return o.str();
    }
    const std::string& id = t.c_identifier;
    const std::string ID = to_upper(id);
    o << "#ifndef " << ID << "_H\n#define " << ID << "_H\n\n#include <stdint.h>\n\n";
    for (const std::string& line : t.c_defines) o << line << "\n";
    o << "\n";
    o << "static const char " << id << "_metadata[] =\n    " << c_string(t.metadata.dump()) << ";\n\n";
    o << "static const " << c_type(encoding) << " " << id << "_data[" << ID << "_DEPTH * " << ID << "_HEIGHT * " << ID << "_WIDTH * "
      << t.channels << "u] = {\n"
      << c_values(t, encoding) << "};\n\n#endif\n";
    return o.str();
}

void write_texture(OutputSet& outputs, const TextureFiles& files, const TextureData& t, PixelEncoding encoding) {
    if (!format_supports(files.format, encoding))
        throw std::invalid_argument(outputs.target(files.file).named + ": the " + to_string(files.format) + " format cannot store " +
                                    to_string(encoding));
    switch (files.format) {
        case TextureFormat::exr: {
            const bool half = encoding == PixelEncoding::float16;
            std::vector<std::string> names;
            const Imf::Header header = exr_header(t, half, names);
            exr::write_interleaved_file(outputs.temp_path(files.file), outputs.target(files.file).named, header, names, t.levels[0],
                                        t.channels, half);
            return;
        }
        case TextureFormat::ktx2: {
            const std::vector<std::uint8_t> bytes = encode_ktx2_texture(t, encoding);
            outputs.stream(files.file).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
            return;
        }
        case TextureFormat::dds: {
            const std::vector<std::uint8_t> bytes = encode_dds_texture(t, encoding);
            outputs.stream(files.sidecar.value()) << dds_sidecar_json(t, encoding).dump(2) << "\n";
            outputs.stream(files.file).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
            return;
        }
        case TextureFormat::header:
        case TextureFormat::inc:
            outputs.stream(files.file) << c_source(t, encoding, files.format == TextureFormat::inc);
            return;
        case TextureFormat::png:
            check_single_image(t, files.format);
            write_png_image(outputs, files, t, encoding);
            return;
    }
}

void write_texture(const std::string& path, TextureFormat format, const TextureData& t, PixelEncoding encoding) {
    OutputSet outputs;
    const TextureFiles files = add_texture_files(outputs, path, format);
    write_texture(outputs, files, t, encoding);
    outputs.commit();
}

void write_exr_texture(const std::string& path, const TextureData& t, bool half) {
    std::vector<std::string> names;
    const Imf::Header header = exr_header(t, half, names);
    exr::write_interleaved(path, header, names, t.levels[0], t.channels, half);
}

}  // namespace ms::lutfmt
