#include "lut/formats/texture_format.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>

namespace ms::lutfmt {

namespace {

using E = PixelEncoding;
using U = TextureUse;

// The one table (texture_format.hpp shows it); every list and check below reads it.
const std::vector<TextureFormatInfo>& table() {
    static const std::vector<TextureFormatInfo> formats = {
        {TextureFormat::exr, "exr", {".exr"}, {E::float32, E::float16}, false, true, {U::lut, U::dfg, U::representation, U::cubemap}},
        {TextureFormat::ktx2, "ktx2", {".ktx2"}, {E::float32, E::float16, E::unorm8, E::unorm16}, false, true,
         {U::lut, U::dfg, U::representation, U::cubemap}},
        {TextureFormat::dds, "dds", {".dds"}, {E::float32, E::float16, E::unorm8, E::unorm16}, true, true,
         {U::lut, U::dfg, U::representation, U::cubemap}},
        {TextureFormat::header, "header", {".h", ".hpp", ".hh"}, {E::float32, E::float16, E::unorm8, E::unorm16}, false, false,
         {U::lut, U::dfg}},
        {TextureFormat::inc, "inc", {".inc"}, {E::float32, E::float16, E::unorm8, E::unorm16}, false, false, {U::lut, U::dfg}},
        {TextureFormat::png, "png", {".png"}, {E::unorm8, E::unorm16}, false, true, {U::lut, U::dfg}},
    };
    return formats;
}

std::string joined(const std::vector<std::string>& items, const std::string& last) {
    std::string out;
    for (std::size_t i = 0; i < items.size(); ++i) {
        if (i > 0) out += i + 1 == items.size() ? last : ", ";
        out += items[i];
    }
    return out;
}

std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

}  // namespace

const std::vector<TextureFormatInfo>& texture_formats() { return table(); }

const TextureFormatInfo& format_info(TextureFormat format) {
    for (const auto& info : table())
        if (info.format == format) return info;
    throw std::logic_error("texture format missing from the table");
}

std::string to_string(TextureFormat format) { return format_info(format).name; }

bool format_supports(TextureFormat format, PixelEncoding encoding) {
    const auto& e = format_info(format).encodings;
    return std::find(e.begin(), e.end(), encoding) != e.end();
}

bool format_allowed(TextureFormat format, TextureUse use) {
    const auto& u = format_info(format).uses;
    return std::find(u.begin(), u.end(), use) != u.end();
}

std::vector<TextureFormat> formats_for(TextureUse use) {
    std::vector<TextureFormat> out;
    for (const auto& info : table())
        if (format_allowed(info.format, use)) out.push_back(info.format);
    return out;
}

std::vector<std::string> format_names(TextureUse use) {
    std::vector<std::string> out;
    for (TextureFormat f : formats_for(use)) out.push_back(to_string(f));
    return out;
}

std::string format_list(TextureUse use, const std::string& last) { return joined(format_names(use), last); }

std::string extension_list(TextureUse use, const std::string& last) {
    std::vector<std::string> extensions;
    for (TextureFormat f : formats_for(use))
        for (const char* e : format_info(f).extensions) extensions.push_back(e);
    return joined(extensions, last);
}

const char* use_noun(TextureUse use) {
    switch (use) {
        case TextureUse::lut: return "LUT";
        case TextureUse::dfg: return "DFG LUT";
        case TextureUse::representation: return "representation";
        case TextureUse::cubemap: return "cubemap";
    }
    return "texture";
}

std::optional<TextureFormat> format_for_extension(const std::string& path) {
    const std::string ext = lower_extension(path);
    for (const auto& info : table())
        for (const char* e : info.extensions)
            if (ext == e) return info.format;
    return std::nullopt;
}

TextureFormat texture_format_for_path(const std::string& path, TextureUse use) {
    const auto format = format_for_extension(path);
    if (format && format_allowed(*format, use)) return *format;
    throw std::invalid_argument(path + ": unknown " + use_noun(use) + " file extension '" + lower_extension(path) +
                                "': the extension picks the format, and a " + use_noun(use) + " is written as " + extension_list(use));
}

TextureFormat parse_texture_format(const std::string& name, TextureUse use) {
    for (TextureFormat f : formats_for(use))
        if (name == to_string(f)) return f;
    throw std::invalid_argument("--format must be " + format_list(use) + ", not '" + name + "'");
}

std::string file_name(const std::string& stem, TextureFormat format) { return stem + format_info(format).extensions.front(); }

}  // namespace ms::lutfmt
