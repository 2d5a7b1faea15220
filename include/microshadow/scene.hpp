// Scenes (included by <microshadow/microshadow.hpp>): `microshadow scene DESCRIPTION.toml` as a call
// that returns every per-pixel layer and the report (docs/scenes.md has the description's format).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// The command's options; the description's own settings apply where these are not set.
struct SceneOptions {
    double tolerance = 0;            // > 0: the per-pixel error bound, overriding sampling.tolerance
    std::optional<Method> method;    // overrides sampling.method (its default tolerance then applies)
    std::vector<std::string> luts;   // more LUT files to compare
    bool skip = true;                // false: every unmasked pixel's own query (the baseline of skipping)
    bool seed_luts = true;           // false: do not bake the seed's 3D and 2D LUTs as comparators
    bool strict_domain = false;      // refuse a comparator looked up outside its domain at a lit pixel
    Backend backend = Backend::opencl;
    std::string device = "default";
    bool fast_math = false;
};

// One image of the result: width x height floats, row-major from the top row.
struct SceneLayer {
    std::string name;  // as in scene.exr: "mask", "<light>.reference", "<light>.std_error", "<light>.weight",
                       // "<light>.<comparator>", "<light>.<comparator>_error"
    std::vector<float> pixels;
};

class SceneResult {
public:
    std::uint32_t width() const;
    std::uint32_t height() const;
    std::vector<std::string> lights() const;
    std::vector<std::string> comparators() const;
    // Every layer, in scene.exr's order.
    std::vector<SceneLayer> layers() const;
    // report.json's content: sizes, counts, tolerance, per light and comparator the error statistics, and
    // the provenance.
    std::string report_json() const;
    // Writes the command's outputs into DIR (created if missing): scene.exr, report.json, report.md and
    // the PNG images, all or none.
    void save(const std::string& dir) const;

    struct Data;
    explicit SceneResult(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

// Runs the scene. std::invalid_argument for a bad description (naming the file and key) or option;
// `progress` is told (done, total) of each phase (LUT bakes, classification, sampling) and may stop it.
SceneResult scene(const std::string& description_path, const SceneOptions& options = {}, const Progress& progress = {});

}  // namespace microshadow
