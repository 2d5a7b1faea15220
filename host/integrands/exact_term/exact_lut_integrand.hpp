// A LUT bake by the exact method: one work item per (roughness, NdotV) slice, in the order of the sampled
// LUT slice integrand (slice = NdotV index * channels + channel), each texel the exact azimuth mean (or
// the exact term at the spec's fixed azimuth) with its estimated error. Rows a partial bake does not
// want (LutSliceSpec::baked_rows) hold NaN, as in the sampled bake.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "integrands/exact_term/exact_term_integrand.hpp"
#include "integrands/lut_slice/lut_slice_spec.hpp"
#include "schedule/integrand.hpp"

namespace ms::exact_term {

class ExactLutIntegrand final : public schedule::Integrand {
public:
    ExactLutIntegrand(const LutSliceSpec& spec, ExactConfig config);
    std::string name() const override { return "LUT slices (exact)"; }
    std::uint64_t work_items() const override;
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override;
    std::unique_ptr<schedule::Worker> oracle_worker() override;
    // A slice's texels (value, error, row by row), its largest error and its quadrature pieces.
    bool distributable() const override { return true; }
    std::string save_item(std::uint64_t id) const override;
    void load_item(std::uint64_t id, const std::string& bytes) override;
    std::string check_item(std::uint64_t id, const std::string& bytes) const override;

    // Atlas order (grid/atlas.hpp), float: value and estimated error per texel and channel.
    const std::vector<float>& values() const { return values_; }
    const std::vector<float>& errors() const { return errors_; }
    double max_error() const;                 // over computed texels
    std::uint64_t quadrature_pieces() const;  // summed over texels (azimuth pieces of the means)
    std::uint64_t exact_zero() const { return zero_; }
    std::uint64_t exact_one() const { return one_; }

    void run_slice(Evaluator& evaluator, std::uint64_t slice);

private:
    LutSliceSpec spec_;
    ExactConfig config_;
    std::uint32_t channels_;
    std::vector<float> values_, errors_;
    std::vector<double> slice_max_error_;
    std::vector<std::uint64_t> slice_pieces_;
    std::uint64_t zero_ = 0, one_ = 0;  // per layout, counted once (the same in every slice)
};

}  // namespace ms::exact_term
