// microshadow shader: GLSL or HLSL that samples a baked LUT (lut/shader/shader_gen.hpp), generated from
// the metadata of the LUT file in any format the bake writes.
#include <filesystem>
#include <iostream>

#include "cli/common.hpp"
#include "lut/exr_lut.hpp"
#include "lut/shader/compose.hpp"
#include "lut/shader/shader_gen.hpp"

namespace ms::cli {

namespace {

struct ShaderArgs {
    std::string lut, lang = "glsl", out, prefix;
};

void run_shader(const ShaderArgs& a) {
    const auto language = lutshader::parse_shader_language(a.lang);
    LutFile lut;
    try {
        lut = read_lut(a.lut);  // any format the bake writes (lut/formats/lut_reader.hpp)
    } catch (const std::runtime_error& e) {
        // A bad or missing input file is bad input (exit 2), not a failure while running.
        throw std::invalid_argument(e.what());
    }
    const std::string name = std::filesystem::path(a.lut).filename().string();
    if (a.out.empty()) std::cout << lutshader::compose(lutshader::generate_shader(lut, language, name), language,
                                                       a.prefix.empty() ? lutshader::default_prefix("") : a.prefix);
    else lutshader::write_shader(a.out, lut, language, name, a.prefix);
}

}  // namespace

void add_shader_command(CLI::App& app) {
    auto a = std::make_shared<ShaderArgs>();
    auto* cmd = app.add_subcommand("shader", "write GLSL or HLSL that samples a baked LUT as a renderer should");
    cmd->add_option("lut", a->lut, "a LUT written by `microshadow bake` (.exr, .ktx2, .dds, .h, .inc or .png)")->required();
    cmd->add_option("--lang", a->lang, "glsl, hlsl or wgsl")->check(CLI::IsMember({"glsl", "hlsl", "wgsl"}))->capture_default_str();
    cmd->add_option("--out", a->out, "output file (default: standard output)");
    add_shader_prefix_option(cmd, a->prefix);
    cmd->callback([a] { run_shader(*a); });
}

}  // namespace ms::cli
