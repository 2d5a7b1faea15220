#include "lut/formats/c_header.hpp"

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "io/text.hpp"

namespace ms::lutfmt {

std::string c_identifier_for(const std::string& path) {
    std::string stem = std::filesystem::path(path).stem().string(), id;
    for (char ch : stem) id += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
    if (id.empty() || std::isdigit(static_cast<unsigned char>(id[0]))) id = "lut_" + id;
    return id;
}

namespace {

std::string printed(const char* format, const std::string& id, const char* name, double v) {
    char buf[160];
    std::snprintf(buf, sizeof buf, format, id.c_str(), name, v);
    return buf;
}

}  // namespace

TextureData c_lut_texture(const std::string& path, const LutFile& lut, PixelEncoding encoding, bool inc_only) {
    check_lut_shape(lut);
    TextureData t;
    t.width = lut.width;
    t.height = lut.height;
    t.channels = 4;
    t.levels = {rgba_padded(lut)};
    t.metadata = format_metadata(lut, encoding, inc_only ? "c-inc" : "c-header", true);
    t.c_identifier = c_identifier_for(path);
    const nlohmann::json& meta = t.metadata;
    const std::string ID = to_upper(t.c_identifier);
    const bool three_d = lut.n_dot_v().count > 1;
    auto& c = t.c_comment;
    {
        std::ostringstream o;
        o << "microshadow LUT (" << meta.value("layout", std::string("?")) << "), written by microshadow " << MICROSHADOW_VERSION
          << ". Generated: do not edit.";
        c.push_back(o.str());
        o.str("");
        o << (three_d ? "3D texture" : "2D texture") << ": width " << lut.visibility().count << " (visibility), height "
          << lut.n_dot_l().count << " (NdotL, increasing downwards)"
          << (three_d ? ", depth " + std::to_string(lut.n_dot_v().count) + " (NdotV)" : "") << "; 4 components per texel, "
          << to_string(encoding) << ".";
        c.push_back(o.str());
    }
    c.push_back("index = ((z * height + y) * width + x) * 4 + c; sample with linear filtering, clamp-to-edge, no mips.");
    for (const auto& a : lut.axes) {
        std::ostringstream o;
        o << "axis " << a.name << ": [" << a.min << ", " << a.max << "], " << a.count << " texels, "
          << (a.texel == TexelConvention::centres ? "texel centres: p_i = min + (max - min) (i + 0.5) / n"
                                                  : "endpoints: p_i = min + (max - min) i / (n - 1)");
        c.push_back(o.str());
    }
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t k = 0; k < 4; ++k) {
        std::ostringstream o;
        if (k < lut.channels.size())
            o << "channel " << names[k] << ": roughness " << lut.channels[k].roughness << " (alpha " << lut.channels[k].alpha_x << ")";
        else
            o << "channel " << names[k] << ": padding, repeats channel " << names[lut.channels.size() - 1];
        c.push_back(o.str());
    }
    const auto& b = meta.at("error_budget");
    {
        std::ostringstream o;
        o << "error budget: sampling " << b.at("sampling").get<double>() << " + azimuth quadrature "
          << b.at("azimuth_quadrature").get<double>() << " + quantisation " << b.at("quantisation").get<double>() << " = "
          << b.at("total").get<double>();
        c.push_back(o.str());
    }
    if (inc_only) return t;
    auto& d = t.c_defines;
    d.push_back("#define " + ID + "_WIDTH " + std::to_string(lut.visibility().count) + "u  /* visibility texels */");
    d.push_back("#define " + ID + "_HEIGHT " + std::to_string(lut.n_dot_l().count) + "u  /* NdotL texels */");
    d.push_back("#define " + ID + "_DEPTH " + std::to_string(lut.n_dot_v().count) + "u  /* NdotV texels (1: a 2D texture) */");
    d.push_back("#define " + ID + "_COMPONENTS 4u");
    d.push_back("#define " + ID + "_ROUGHNESS_CHANNELS " + std::to_string(lut.channels.size()) + "u");
    const char* axis_ids[3] = {"VISIBILITY", "N_DOT_L", "N_DOT_V"};
    for (std::size_t i = 0; i < 3; ++i) {
        const auto& a = lut.axes[i];
        d.push_back(printed("#define %s_%s_MIN %.17g", ID, axis_ids[i], a.min));
        d.push_back(printed("#define %s_%s_MAX %.17g", ID, axis_ids[i], a.max));
        d.push_back("#define " + ID + "_" + axis_ids[i] + "_TEXEL_CENTRES " + (a.texel == TexelConvention::centres ? "1" : "0"));
    }
    for (std::size_t k = 0; k < lut.channels.size(); ++k)
        d.push_back(printed("#define %s_ROUGHNESS_%s %.17g", ID, names[k], lut.channels[k].roughness));
    d.push_back(printed("#define %s_%s %.6g", ID, "MAX_TOTAL_ERROR", b.at("total").get<double>()));
    d.push_back("#define " + ID + "_COSINE_AO " + (meta.value("ao_weighting", std::string("cosine")) == "cosine" ? "1" : "0") +
                "  /* zero region: 2 v + NdotL <= 1 (cosine) or NdotL <= 2 (1 - v)^2 - 1 (uniform) */");
    return t;
}

}  // namespace ms::lutfmt
