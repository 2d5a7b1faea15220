#include "lut/formats/c_header.hpp"

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "lut/formats/binary_writer.hpp"
#include "io/text.hpp"

namespace ms::lutfmt {

std::string c_identifier_for(const std::string& path) {
    std::string stem = std::filesystem::path(path).stem().string(), id;
    for (char ch : stem) id += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
    if (id.empty() || std::isdigit(static_cast<unsigned char>(id[0]))) id = "lut_" + id;
    return id;
}

namespace {

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

// A float literal that reads back as the same float ("%.9g" is enough digits for binary32).
std::string float_literal(float v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", double(v));
    std::string s = buf;
    if (s.find_first_of(".eE") == std::string::npos) s += ".0";
    return s + "f";
}

std::string values(const LutFile& lut, PixelEncoding encoding) {
    const std::vector<float> rgba = rgba_padded(lut);
    std::ostringstream out;
    const std::size_t per_line = encoding == PixelEncoding::float32 ? 4 : 8;
    for (std::size_t i = 0; i < rgba.size(); ++i) {
        if (i % per_line == 0) out << "    ";
        switch (encoding) {
            case PixelEncoding::float32: out << float_literal(rgba[i]); break;
            case PixelEncoding::float16: {
                char buf[12];
                std::snprintf(buf, sizeof buf, "0x%04x", unsigned(float_to_half(rgba[i])));
                out << buf;
                break;
            }
            case PixelEncoding::unorm8: out << to_unorm(rgba[i], 8); break;
            case PixelEncoding::unorm16: out << to_unorm(rgba[i], 16); break;
        }
        out << (i + 1 == rgba.size() ? "\n" : (i % per_line == per_line - 1 ? ",\n" : ", "));
    }
    return out.str();
}

const char* c_type(PixelEncoding e) {
    return e == PixelEncoding::float32 ? "float" : e == PixelEncoding::unorm8 ? "uint8_t" : "uint16_t";
}

}  // namespace

void write_c_header(const std::string& path, const LutFile& lut, PixelEncoding encoding, bool inc_only) {
    check_lut_shape(lut);
    const nlohmann::json meta = format_metadata(lut, encoding, inc_only ? "c-inc" : "c-header", true);
    const std::string id = c_identifier_for(path), ID = to_upper(id);
    const bool three_d = lut.n_dot_v().count > 1;
    std::ostringstream o;
    o << "/* microshadow LUT (" << meta.value("layout", std::string("?")) << "), written by microshadow " << MICROSHADOW_VERSION
      << ". Generated: do not edit.\n"
      << " * " << (three_d ? "3D texture" : "2D texture") << ": width " << lut.visibility().count << " (visibility), height "
      << lut.n_dot_l().count << " (NdotL, increasing downwards)" << (three_d ? ", depth " + std::to_string(lut.n_dot_v().count) + " (NdotV)" : "")
      << "; 4 components per texel, " << to_string(encoding) << ".\n"
      << " * index = ((z * height + y) * width + x) * 4 + c; sample with linear filtering, clamp-to-edge, no mips.\n";
    for (const auto& a : lut.axes)
        o << " * axis " << a.name << ": [" << a.min << ", " << a.max << "], " << a.count << " texels, "
          << (a.texel == TexelConvention::centres ? "texel centres: p_i = min + (max - min) (i + 0.5) / n"
                                                  : "endpoints: p_i = min + (max - min) i / (n - 1)")
          << "\n";
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < 4; ++c) {
        if (c < lut.channels.size())
            o << " * channel " << names[c] << ": roughness " << lut.channels[c].roughness << " (alpha " << lut.channels[c].alpha_x << ")\n";
        else
            o << " * channel " << names[c] << ": padding, repeats channel " << names[lut.channels.size() - 1] << "\n";
    }
    const auto& b = meta.at("error_budget");
    o << " * error budget: sampling " << b.at("sampling").get<double>() << " + azimuth quadrature "
      << b.at("azimuth_quadrature").get<double>() << " + quantisation " << b.at("quantisation").get<double>() << " = "
      << b.at("total").get<double>() << "\n */\n";
    if (inc_only) {
        // The whole metadata on one line, so that the values can be read back as a LUT (lut_reader.hpp).
        // '/' is written "\/" (the same string to a JSON parser): no "*/" can end the comment early.
        std::string json;
        for (char ch : meta.dump()) json += ch == '/' ? std::string("\\/") : std::string(1, ch);
        o << "/* microshadow-metadata: " << json << " */\n";
        o << "/* " << c_type(encoding) << " values; #include inside an initialiser */\n" << values(lut, encoding);
        write_text_atomically(path, o.str());
        return;
    }
    o << "#ifndef " << ID << "_H\n#define " << ID << "_H\n\n#include <stdint.h>\n\n";
    o << "#define " << ID << "_WIDTH " << lut.visibility().count << "u  /* visibility texels */\n";
    o << "#define " << ID << "_HEIGHT " << lut.n_dot_l().count << "u  /* NdotL texels */\n";
    o << "#define " << ID << "_DEPTH " << lut.n_dot_v().count << "u  /* NdotV texels (1: a 2D texture) */\n";
    o << "#define " << ID << "_COMPONENTS 4u\n";
    o << "#define " << ID << "_ROUGHNESS_CHANNELS " << lut.channels.size() << "u\n";
    const char* axis_ids[3] = {"VISIBILITY", "N_DOT_L", "N_DOT_V"};
    for (std::size_t i = 0; i < 3; ++i) {
        const auto& a = lut.axes[i];
        char buf[160];
        std::snprintf(buf, sizeof buf, "#define %s_%s_MIN %.17g\n#define %s_%s_MAX %.17g\n#define %s_%s_TEXEL_CENTRES %d\n",
                      ID.c_str(), axis_ids[i], a.min, ID.c_str(), axis_ids[i], a.max, ID.c_str(), axis_ids[i],
                      a.texel == TexelConvention::centres ? 1 : 0);
        o << buf;
    }
    for (std::size_t c = 0; c < lut.channels.size(); ++c) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "#define %s_ROUGHNESS_%s %.17g\n", ID.c_str(), names[c], lut.channels[c].roughness);
        o << buf;
    }
    {
        char buf[96];
        std::snprintf(buf, sizeof buf, "#define %s_MAX_TOTAL_ERROR %.6g\n", ID.c_str(), b.at("total").get<double>());
        o << buf;
    }
    o << "#define " << ID << "_COSINE_AO " << (meta.value("ao_weighting", std::string("cosine")) == "cosine" ? 1 : 0)
      << "  /* zero region: 2 v + NdotL <= 1 (cosine) or NdotL <= 2 (1 - v)^2 - 1 (uniform) */\n\n";
    o << "static const char " << id << "_metadata[] =\n    " << c_string(meta.dump()) << ";\n\n";
    o << "static const " << c_type(encoding) << " " << id << "_data[" << ID << "_DEPTH * " << ID << "_HEIGHT * " << ID
      << "_WIDTH * 4u] = {\n"
      << values(lut, encoding) << "};\n\n#endif\n";
    write_text_atomically(path, o.str());
}

}  // namespace ms::lutfmt
