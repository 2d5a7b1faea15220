// microshadow lut: a baked LUT file in any format the bake writes (lut/formats/lut_reader.hpp).
// `lut info` prints its layout, encoding, error budget and provenance; `lut export` writes it again
// in another format or encoding (what --format/--encoding would have written at bake time).
#include <filesystem>
#include <iostream>
#include <sstream>

#include "cli/common.hpp"
#include "io/atomic_file.hpp"
#include "io/text.hpp"
#include "lut/formats/lut_formats.hpp"
#include "lut/formats/lut_reader.hpp"

namespace ms::cli {

namespace {

struct LutInfoArgs {
    std::string file;
    bool metadata = false;
};

struct LutExportArgs {
    std::string file, out, format, encoding;
    bool half = false;
};

// A LUT that cannot be read is bad input (exit status 2), with the reader's one-line message.
LutFile open_or_bad_input(const std::string& path, lutfmt::LutFileInfo& info) {
    try {
        return lutfmt::read_lut_file(path, &info);
    } catch (const std::runtime_error& e) {
        throw std::invalid_argument(e.what());
    }
}

std::string describe(const LutFile& lut, const lutfmt::LutFileInfo& info, const std::string& path) {
    std::ostringstream o;
    const bool three_d = lut.n_dot_v().count > 1;
    const double step = lutfmt::encoding_step_bound(info.encoding);
    o << path << ": LUT, " << lutfmt::to_string(info.format) << " " << lutfmt::to_string(info.encoding);
    // A float copy of an earlier quantised file (a PNG exported to EXR) holds that file's steps, not
    // the baked floats: say so, with the bound the export recorded.
    double earlier = 0;
    if (lut.metadata.contains("error_budget") && lut.metadata.at("error_budget").is_object()) {
        const auto& b = lut.metadata.at("error_budget");
        if (b.contains("earlier_quantisation") && b.at("earlier_quantisation").is_number()) earlier = b.at("earlier_quantisation").get<double>();
    }
    if (earlier == 0 && lut.metadata.contains("earlier_quantisation_error") && lut.metadata.at("earlier_quantisation_error").is_number())
        earlier = lut.metadata.at("earlier_quantisation_error").get<double>();
    std::string from;
    if (lut.metadata.contains("exported_from") && lut.metadata.at("exported_from").is_object())
        from = lut.metadata.at("exported_from").value("encoding", std::string()) + " " +
               lut.metadata.at("exported_from").value("format", std::string());
    if (earlier > 0)
        o << " (exported from an earlier " << (from.size() > 1 ? from + " " : std::string()) << "file: each texel within "
          << step + earlier << " of the baked float)\n";
    else if (step == 0) o << " (the baked floats exactly)\n";
    else o << " (each texel within " << step << " of the baked float)\n";
    o << "layout: " << lut.metadata.value("layout", std::string("?")) << ", " << (three_d ? "3D" : "2D") << " texture "
      << lut.visibility().count << " x " << lut.n_dot_l().count << (three_d ? " x " + std::to_string(lut.n_dot_v().count) : "")
      << " (visibility x NdotL" << (three_d ? " x NdotV" : "") << "), " << lut.channels.size() << " roughness channel"
      << (lut.channels.size() == 1 ? "" : "s") << "\n";
    for (const auto& a : lut.axes)
        o << "axis " << a.name << ": [" << a.min << ", " << a.max << "], " << a.count << " texels, "
          << (a.texel == TexelConvention::centres ? "texel centres" : "endpoints") << "\n";
    for (const auto& c : lut.channels) o << "channel " << c.name << ": roughness " << c.roughness << " (alpha " << c.alpha_x << ")\n";
    if (lut.metadata.contains("error_budget") && lut.metadata.at("error_budget").is_object()) {
        const auto& b = lut.metadata.at("error_budget");
        auto term = [&](const char* key) { return b.contains(key) && b.at(key).is_number() ? b.at(key).get<double>() : 0.0; };
        o << "error budget: sampling " << term("sampling") << " + azimuth quadrature " << term("azimuth_quadrature");
        if (b.contains("earlier_quantisation")) o << " + earlier quantisation " << term("earlier_quantisation");
        o << " + quantisation " << term("quantisation") << " = " << term("total") << "\n";
    }
    if (is_partial_bake(lut)) o << "partial bake: unbaked texels are NaN (see \"coverage\" in the metadata)\n";
    const std::string version = lut.metadata.value("version", std::string("?"));
    o << "made by: microshadow " << version;
    if (lut.metadata.contains("command_line") && lut.metadata.at("command_line").is_string())
        o << ": " << lut.metadata.at("command_line").get<std::string>();
    o << "\n";
    return o.str();
}

void run_lut_export(const LutExportArgs& a) {
    lutfmt::LutFileInfo from;
    // The output is checked before the input is read: nothing is written on a bad request.
    const lutfmt::LutOutput output = lutfmt::resolve_lut_output(a.out, a.format, a.encoding, a.half);
    check_writable_destination(a.out);
    if (lutfmt::format_info(output.format).sidecar) check_writable_destination(a.out + ".json");
    LutFile lut = open_or_bad_input(a.file, from);
    lut = lutfmt::lut_for_export(std::move(lut), from, json_safe(a.file));
    // The bake's command line stays the LUT's provenance; the export's is recorded beside the source.
    lut.metadata["exported_from"]["command_line"] = command_line();
    lutfmt::write_lut_output(a.out, lut, output);
}

}  // namespace

void add_lut_command(CLI::App& app) {
    auto* lut_cmd = app.add_subcommand("lut", "a baked LUT in any format the bake writes: info, export");
    lut_cmd->require_subcommand(1);

    auto i = std::make_shared<LutInfoArgs>();
    auto* info = lut_cmd->add_subcommand("info", "print a LUT file's format, layout, error budget and provenance");
    info->add_option("file", i->file, "a LUT written by `microshadow bake` (" + lutfmt::extension_list(lutfmt::TextureUse::lut) + ")")->required();
    info->add_flag("--metadata,--json", i->metadata, "also print the whole metadata record (JSON)");
    info->callback([i] {
        lutfmt::LutFileInfo format;
        const LutFile lut = open_or_bad_input(i->file, format);
        std::cout << describe(lut, format, i->file);
        if (i->metadata) std::cout << lut.metadata.dump(2) << "\n";
    });

    auto x = std::make_shared<LutExportArgs>();
    auto* exp = lut_cmd->add_subcommand("export", "write a LUT file again in another format or encoding");
    exp->add_option("file", x->file, "a LUT written by `microshadow bake` (any of its formats)")->required();
    exp->add_option("--out", x->out, "the new file: " + lutfmt::extension_list(lutfmt::TextureUse::lut) + " (.dds: + .dds.json)")->required();
    exp->add_option("--format", x->format, "must agree with --out's extension: " + lutfmt::format_list(lutfmt::TextureUse::lut))
        ->check(CLI::IsMember(lutfmt::format_names(lutfmt::TextureUse::lut)));
    exp->add_option("--encoding", x->encoding, "stored values: float32, float16 (= --half), unorm8, unorm16 (default: float32; png: unorm8)")
        ->check(CLI::IsMember({"float32", "float16", "unorm8", "unorm16", "float", "half", "rgba8", "rgba16"}));
    exp->add_flag("--half", x->half, "--encoding float16");
    exp->callback([x] { run_lut_export(*x); });
}

}  // namespace ms::cli
