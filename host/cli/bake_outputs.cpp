#include "cli/bake_outputs.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>

#include "cli/common.hpp"
#include "lut/shader/shader_gen.hpp"

namespace ms::cli {

namespace {

std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

// Two spellings of one file ("out/a.exr" and "./out/../out/a.exr") are the same destination.
bool same_file(const std::string& a, const std::string& b) {
    namespace fs = std::filesystem;
    std::error_code ea, eb;
    const fs::path pa = fs::weakly_canonical(a, ea), pb = fs::weakly_canonical(b, eb);
    return (ea || eb) ? a == b : pa == pb;
}

void check_shader_path(const std::string& path, const char* option, std::initializer_list<const char*> extensions,
                       const std::string& out, const std::string& preview) {
    if (path.empty()) return;
    const std::string ext = lower_extension(path);
    if (std::none_of(extensions.begin(), extensions.end(), [&](const char* e) { return ext == e; }))
        throw std::invalid_argument(std::string(option) + " " + path + ": expected a " + *extensions.begin() + " file");
    if (same_file(path, out)) throw std::invalid_argument(std::string(option) + " is the --out file " + out);
    if (!preview.empty() && same_file(path, preview)) throw std::invalid_argument(std::string(option) + " is the --preview file");
}

}  // namespace

void add_bake_output_options(CLI::App* cmd, BakeOutputArgs& a) {
    cmd->add_option("--format", a.format, "LUT file format; must agree with --out's extension: " + lutfmt::format_list(lutfmt::TextureUse::lut))
        ->check(CLI::IsMember(lutfmt::format_names(lutfmt::TextureUse::lut)));
    cmd->add_option("--encoding", a.encoding,
                    "stored values: float32, float16 (= --half), unorm8, unorm16 (default: float32; png: unorm8)")
        ->check(CLI::IsMember({"float32", "float16", "unorm8", "unorm16", "float", "half", "rgba8", "rgba16"}));
    cmd->add_option("--shader-glsl", a.shader_glsl, "also write GLSL that samples this LUT (F.glsl)");
    cmd->add_option("--shader-hlsl", a.shader_hlsl, "also write HLSL that samples this LUT (F.hlsl)");
    cmd->add_option("--shader-wgsl", a.shader_wgsl, "also write WGSL that samples this LUT (F.wgsl)");
    add_shader_prefix_option(cmd, a.shader_prefix);
}

lutfmt::LutOutput check_bake_outputs(const BakeOutputArgs& a, const std::string& out, const std::string& preview, bool half) {
    const lutfmt::LutOutput output = lutfmt::resolve_lut_output(out, a.format, a.encoding, half);
    if (!preview.empty()) {
        if (lower_extension(preview) != ".png")
            throw std::invalid_argument("--preview " + preview + ": the preview is a PNG picture; give a .png file");
        if (same_file(preview, out)) throw std::invalid_argument("--preview is the --out file " + out + ": one would overwrite the other");
    }
    check_shader_path(a.shader_glsl, "--shader-glsl", {".glsl", ".comp", ".frag"}, out, preview);
    check_shader_path(a.shader_hlsl, "--shader-hlsl", {".hlsl", ".hlsli"}, out, preview);
    check_shader_path(a.shader_wgsl, "--shader-wgsl", {".wgsl"}, out, preview);
    if (!a.shader_glsl.empty() && !a.shader_hlsl.empty() && same_file(a.shader_glsl, a.shader_hlsl))
        throw std::invalid_argument("--shader-glsl and --shader-hlsl are the same file");
    return output;
}

void write_bake_outputs(const BakeOutputArgs& a, const lutfmt::LutOutput& output, const std::string& out, const LutFile& lut) {
    // Shaders first, the LUT last: the LUT appearing still means the whole job finished.
    const std::string source = std::filesystem::path(out).filename().string();
    if (!a.shader_glsl.empty()) lutshader::write_shader(a.shader_glsl, lut, lutshader::ShaderLanguage::glsl, source, a.shader_prefix);
    if (!a.shader_hlsl.empty()) lutshader::write_shader(a.shader_hlsl, lut, lutshader::ShaderLanguage::hlsl, source, a.shader_prefix);
    if (!a.shader_wgsl.empty()) lutshader::write_shader(a.shader_wgsl, lut, lutshader::ShaderLanguage::wgsl, source, a.shader_prefix);
    lutfmt::write_lut_output(out, lut, output);
}

}  // namespace ms::cli
