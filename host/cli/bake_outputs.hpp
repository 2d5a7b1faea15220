// What `bake` writes besides the numbers: the LUT's file format (by extension or
// --format), its pixel encoding (--encoding, --half), the preview's checks, and generated shaders
// (--shader-glsl, --shader-hlsl). Kept out of cmd_bake.cpp so the bake itself stays one job.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/lut_formats.hpp"

namespace ms::cli {

struct BakeOutputArgs {
    std::string format, encoding, shader_glsl, shader_hlsl, shader_wgsl, shader_prefix;
};

void add_bake_output_options(CLI::App* cmd, BakeOutputArgs& args);

// Checks everything about the outputs before the bake runs; throws std::invalid_argument naming the
// option: unknown or mismatched extension, an encoding the format cannot hold, --preview that is not
// a .png or is the --out file, a shader path that is --out or --preview or has the wrong extension.
lutfmt::LutOutput check_bake_outputs(const BakeOutputArgs& args, const std::string& out, const std::string& preview, bool half);

// Writes the shaders, then the LUT in its format (each atomic).
void write_bake_outputs(const BakeOutputArgs& args, const lutfmt::LutOutput& output, const std::string& out, const LutFile& lut);

}  // namespace ms::cli
