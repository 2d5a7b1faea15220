// libFuzzer target: the query readers of `microshadow area eval` (sphere and rectangle lights) and the
// light geometry every accepted query goes through before sampling.
// Contract under test: every input either yields queries that area::validate accepts, whose geometry
// (classification, highest direction, solid angle, representative point, the light sampler, the taps)
// is finite, or throws ms::CsvError; anything else is a finding.
#include <cmath>
#include <cstdint>

#include "fuzz_common.hpp"
#include "integrands/area_light/area_light_integrand.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "io/csv.hpp"
#include "jobs/area.hpp"

namespace {
bool finite(const ms::Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string& path = ms::fuzz::scratch_path(".csv");
    ms::fuzz::write_scratch(path, data, size);
    for (const auto shape : {ms::area::LightShape::sphere, ms::area::LightShape::rect}) {
        try {
            for (const ms::area::AreaQuery& read : ms::area::read_area_csv(path, shape, ms::area::Lobe::ggx)) {
                try {
                    ms::area::validate(read);
                } catch (const std::invalid_argument&) {
                    ms::fuzz::finding("read_area_csv accepted a query that area::validate rejects");
                }
                const ms::area::AreaQuery q = ms::area::normalised(read);
                const double top = ms::area::max_height(q.light);
                if (!std::isfinite(top) || top > 1 + 1e-12) ms::fuzz::finding("max_height not finite or above 1");
                const double omega = ms::area::solid_angle(q.light);
                if (!(omega > 0) || !(omega < 2 * ms::kPi + 1e-9)) ms::fuzz::finding("solid angle outside (0, 2 pi)");
                (void)ms::area::classify(q, ms::AoWeighting::cosine);
                if (!finite(ms::area::centre_direction(q.light)) || !finite(ms::area::representative_direction(q)))
                    ms::fuzz::finding("centre or representative direction not finite");
                for (double u : {0.0, 0.3, 0.7, 0.999}) {
                    const ms::area::LightSample s = ms::area::sample_light(q, u, 1 - u);
                    if (!std::isfinite(s.weight) || s.weight < 0) ms::fuzz::finding("light sample weight not finite");
                }
                if (shape == ms::area::LightShape::sphere)
                    for (const auto& t : ms::area::sphere_taps(q))
                        if (!finite(t.wo) || !std::isfinite(t.weight) || t.weight < 0) ms::fuzz::finding("tap not finite");
            }
        } catch (const ms::CsvError&) {
        }
    }
    return 0;
}
