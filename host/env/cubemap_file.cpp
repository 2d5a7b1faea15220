#include "env/cubemap_file.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "env/image.hpp"
#include "io/exr_preflight.hpp"
#include "io/input_file.hpp"
#include "lut/formats/texture_reader.hpp"

namespace ms::env {

namespace {

const char* const kFaceNames[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};

std::string lower_extension(const std::string& path) {
    const std::size_t dot = path.find_last_of('.'), slash = path.find_last_of('/');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string ext = path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

}  // namespace

CubemapFile read_cubemap_file(const std::string& path) {
    const auto fail = [&](const std::string& why) { return EnvironmentError("environment " + path + ": " + why); };
    const std::string ext = lower_extension(path);
    if (ext != ".ktx2" && ext != ".dds") throw fail("a cubemap file is .ktx2 or .dds");
    check_environment_file(path);
    lutfmt::TextureFile file;
    try {
        // The six base faces together are bounded like an image's pixels (a forged size is refused before
        // anything is allocated).
        file = ext == ".ktx2" ? lutfmt::read_ktx2_texture(path, exr::kMaxImagePixels) : lutfmt::read_dds_texture(path, exr::kMaxImagePixels);
    } catch (const InputError& e) {
        throw fail(e.what());
    } catch (const std::runtime_error& e) {
        throw fail(e.what());
    }
    const lutfmt::TextureData& t = file.texture;
    if (t.faces != 6)
        throw fail("a " + std::string(t.depth > 1 ? "3D" : "2D") + " texture (faceCount " + std::to_string(t.faces) +
                   "), not a cubemap (faceCount 6)");
    if (file.encoding != lutfmt::PixelEncoding::float16 && file.encoding != lutfmt::PixelEncoding::float32)
        throw fail(lutfmt::to_string(file.encoding) + " texels: a radiance cubemap is float16 or float32 (unorm clips radiance at 1)");
    if (t.channels != 4 || t.levels.empty()) throw fail("no RGBA levels");  // the reader's contract; checked, never assumed

    CubemapFile out;
    out.encoding = lutfmt::to_string(file.encoding);
    out.metadata = t.metadata.is_object() ? t.metadata : nlohmann::json::object();
    // The residue rule needs the file's largest value first (image.hpp: negatives that small are filtering's).
    float largest = 0;
    for (const auto& level : t.levels)
        for (std::size_t i = 0; i < level.size(); ++i)
            if (i % 4 != 3 && std::isfinite(level[i])) largest = std::max(largest, level[i]);
    for (std::size_t p = 0; p < t.levels.size(); ++p) {
        const std::uint32_t n = lutfmt::level_size(t.width, std::uint32_t(p));
        Cubemap cube(n);
        const std::vector<float>& level = t.levels[p];
        if (level.size() != std::size_t(n) * n * 6 * 4) throw fail("level " + std::to_string(p) + " has the wrong texel count");
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x) {
                    const float* rgba = &level[((std::size_t(f) * n + y) * n + x) * 4];
                    float* rgb = cube.texel(f, x, y);
                    for (int c = 0; c < 3; ++c) {
                        float v = rgba[c];
                        if (v < 0 && v >= -kNegativeResidue * largest) {
                            v = 0;
                            ++out.negative_residue_values;
                        }
                        if (!(v >= 0 && v <= kMaxRadiance)) {
                            std::ostringstream s;
                            s << "level " << p << " face " << kFaceNames[f] << " texel (" << x << ", " << y << ") channel " << "RGB"[c]
                              << " is " << v << "; radiance must be finite, non-negative and at most " << kMaxRadiance;
                            throw fail(s.str());
                        }
                        rgb[c] = v;
                    }
                }
        out.levels.push_back(std::move(cube));
    }
    return out;
}

lutfmt::TextureData image_texture(const Image& image, const nlohmann::json& metadata) {
    lutfmt::TextureData t;
    t.width = image.width;
    t.height = image.height;
    t.channels = image.channels;
    t.channel_names = image.channel_names;
    t.levels = {image.data};
    t.metadata = metadata.is_object() ? metadata : nlohmann::json::object();
    return t;
}

lutfmt::TextureData cubemap_texture(const std::vector<const Cubemap*>& levels, const nlohmann::json& metadata) {
    if (levels.empty()) throw std::invalid_argument("cubemap: no levels");
    lutfmt::TextureData t;
    t.width = t.height = levels[0]->size;
    t.faces = 6;
    t.channels = 3;
    t.alpha = 1.0f;
    for (std::size_t m = 0; m < levels.size(); ++m) {
        if (levels[m]->size != lutfmt::level_size(t.width, std::uint32_t(m)))
            throw std::invalid_argument("cubemap: mip " + std::to_string(m) + " is not half the size of the one above");
        std::vector<float> level;
        for (int f = 0; f < 6; ++f) level.insert(level.end(), levels[m]->faces[f].data.begin(), levels[m]->faces[f].data.end());
        t.levels.push_back(std::move(level));
    }
    t.metadata = metadata.is_object() ? metadata : nlohmann::json::object();
    t.metadata["faces"] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    return t;
}

}  // namespace ms::env
