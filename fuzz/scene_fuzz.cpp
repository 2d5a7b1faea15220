// libFuzzer target: scene descriptions with their images, as `microshadow scene` and `bake --scene`
// read them. An input is TOML text, a NUL byte, then the bytes of one small image, saved both as
// img.png and img.exr beside the description (so a description names either reader; the seeds in
// fuzz/scene-seeds have that shape). Contract: load_scene and SceneInputs::load either refuse with
// SceneError (std::invalid_argument), or give inputs whose every shaded pixel has a unit normal and
// view, alpha in [kMinAlpha, 2], visibility in [0, 1] and, under every light, a finite query and an
// irradiance within kMaxIrradiance; under an area light, a query the area checks (core/area_light.hpp) accept.
#include <sys/stat.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "fuzz_common.hpp"
#include "scene/description.hpp"
#include "scene/image_io.hpp"
#include "scene/inputs.hpp"

namespace {

bool unit(const ms::Vec3& v) { return std::fabs(std::hypot(v.x, v.y, v.z) - 1) < 1e-6; }
bool finite(const ms::Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::string dir = [] {
        const std::string d = ms::fuzz::scratch_path(".scene");
        ::mkdir(d.c_str(), 0700);
        return d;
    }();
    const auto* nul = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
    const std::size_t text_size = nul ? std::size_t(nul - data) : size;
    const std::uint8_t* image = nul ? nul + 1 : data + size;
    const std::size_t image_size = nul ? size - text_size - 1 : 0;
    ms::fuzz::write_scratch(dir + "/s.toml", data, text_size);
    ms::fuzz::write_scratch(dir + "/img.png", image, image_size);
    ms::fuzz::write_scratch(dir + "/img.exr", image, image_size);
    try {
        const ms::scene::SceneDescription d = ms::scene::load_scene(dir + "/s.toml");
        const ms::scene::SceneInputs inputs = ms::scene::SceneInputs::load(d);
        if (inputs.width() == 0 || inputs.height() == 0) ms::fuzz::finding("an empty scene accepted");
        for (std::size_t i = 0; i < inputs.pixels(); ++i) {
            const ms::scene::PixelSurface p = inputs.pixel(i);
            if (!p.shaded) continue;
            if (!unit(p.normal) || !unit(p.view)) ms::fuzz::finding("a shaded pixel without a unit normal or view");
            if (!(p.visibility >= 0 && p.visibility <= 1)) ms::fuzz::finding("visibility outside [0, 1] accepted");
            if (!(p.alpha_x >= ms::scene::kMinAlpha && p.alpha_x <= 2 && p.alpha_y >= ms::scene::kMinAlpha && p.alpha_y <= 2))
                ms::fuzz::finding("alpha outside [kMinAlpha, 2]");
            for (const ms::scene::Light& light : d.lights) {
                const ms::scene::LightQuery q = ms::scene::light_query(p, light);
                if (!(q.irradiance >= 0 && q.irradiance <= ms::scene::kMaxIrradiance)) ms::fuzz::finding("an irradiance beyond the limit");
                if (!std::isfinite(q.n_dot_l) || !std::isfinite(q.n_dot_v)) ms::fuzz::finding("a non-finite cosine");
                if (q.status == ms::scene::PixelStatus::shaded && (!finite(q.query.wi) || !finite(q.query.wo)))
                    ms::fuzz::finding("a shaded query with non-finite directions");
                if (!light.is_area()) continue;
                // An area light's query, when it has one, passes the area checks (what the integrand requires).
                const ms::scene::AreaLightQuery a = ms::scene::area_light_query(p, light);
                if (a.status != ms::scene::PixelStatus::shaded) continue;
                try {
                    ms::area::validate(a.query);
                } catch (const std::invalid_argument& e) {
                    ms::fuzz::finding((std::string("a shaded area-light query the area checks refuse: ") + e.what()).c_str());
                }
            }
        }
    } catch (const std::invalid_argument&) {  // SceneError, and the CLI's other bad-input errors
    }
    return 0;
}
