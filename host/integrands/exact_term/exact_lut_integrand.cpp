#include "integrands/exact_term/exact_lut_integrand.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/cone.hpp"
#include "grid/atlas.hpp"
#include "schedule/item_bytes.hpp"

namespace ms::exact_term {

namespace {

class SliceWorker final : public schedule::Worker {
public:
    SliceWorker(ExactLutIntegrand& owner, std::unique_ptr<Evaluator> evaluator)
        : owner_(owner), evaluator_(std::move(evaluator)) {}
    void run(std::uint64_t id) override { owner_.run_slice(*evaluator_, id); }

private:
    ExactLutIntegrand& owner_;
    std::unique_ptr<Evaluator> evaluator_;
};

}  // namespace

ExactLutIntegrand::ExactLutIntegrand(const LutSliceSpec& spec, ExactConfig config)
    : spec_(spec), config_(std::move(config)), channels_(std::uint32_t(spec.roughness.size())) {
    validate(spec_);
    validate_tolerance(config_.tolerance);
    const std::size_t texels = std::size_t(spec_.visibility.count) * spec_.n_dot_l.count * spec_.n_dot_v.count * channels_;
    values_.assign(texels, 0.0f);
    errors_.assign(texels, 0.0f);
    slice_max_error_.assign(work_items(), 0.0);
    slice_pieces_.assign(work_items(), 0);
    for (std::uint32_t il = 0; il < spec_.n_dot_l.count; ++il)
        for (std::uint32_t iv = 0; iv < spec_.visibility.count; ++iv) {
            const double v = spec_.visibility.value(iv);
            const double nl = std::max(spec_.n_dot_l.value(il), kMinNdotL);
            if (in_zero_region(cone_cos_theta(v, spec_.term.ao_weighting), nl)) ++zero_;
            else if (v >= 1) ++one_;
        }
    zero_ *= std::uint64_t(spec_.n_dot_v.count) * channels_;
    one_ *= std::uint64_t(spec_.n_dot_v.count) * channels_;
}

std::uint64_t ExactLutIntegrand::work_items() const { return std::uint64_t(spec_.n_dot_v.count) * channels_; }

std::unique_ptr<schedule::Worker> ExactLutIntegrand::device_worker(ocl::Device& device) {
    return std::make_unique<SliceWorker>(*this, make_place_evaluator(device, config_));
}

std::unique_ptr<schedule::Worker> ExactLutIntegrand::oracle_worker() {
    return std::make_unique<SliceWorker>(*this, make_cpu_evaluator());
}

void ExactLutIntegrand::run_slice(Evaluator& evaluator, std::uint64_t slice) {
    const std::uint32_t ivv = std::uint32_t(slice / channels_), channel = std::uint32_t(slice % channels_);
    const double r = spec_.roughness.at(channel);
    const double nv = std::max(spec_.n_dot_v.value(ivv), kMinNdotV);
    const AtlasShape shape{spec_.visibility.count, spec_.n_dot_l.count, spec_.n_dot_v.count, channels_};
    std::vector<ExactTexel> texels;
    std::vector<std::size_t> where;
    for (std::uint32_t il = 0; il < spec_.n_dot_l.count; ++il) {
        const bool baked = spec_.row_baked(slice, il);
        for (std::uint32_t iv = 0; iv < spec_.visibility.count; ++iv) {
            const std::size_t at = shape.index(channel, iv, il, ivv);
            if (!baked) {
                values_[at] = errors_[at] = std::numeric_limits<float>::quiet_NaN();
                continue;
            }
            texels.push_back({spec_.visibility.value(iv), r * r, nv, std::max(spec_.n_dot_l.value(il), kMinNdotL)});
            where.push_back(at);
        }
    }
    std::vector<exact::ExactValue> out;
    // The float texel's rounding (at most half an ulp of a value below 1, 2^-25) takes its part of the
    // tolerance, so that the evaluator's estimate plus the rounding stays within it.
    const double rounding = std::ldexp(1.0, -25);
    const double evaluator_tolerance = config_.tolerance > 2 * rounding ? config_.tolerance - rounding : config_.tolerance;
    evaluator.texels(texels, spec_.term.ao_weighting, spec_.azimuth_mean, spec_.azimuth_degrees * kPi / 180.0,
                     evaluator_tolerance, out);
    double max_error = 0;
    std::uint64_t pieces = 0;
    for (std::size_t k = 0; k < where.size(); ++k) {
        values_[where[k]] = float(out[k].term);
        // The float texel's rounding joins the estimate, so the recorded error is the stored value's.
        const double stored_error = out[k].error + std::fabs(double(float(out[k].term)) - out[k].term);
        // Stored rounded up, so that the float error still bounds the float value's.
        float recorded = float(stored_error);
        if (double(recorded) < stored_error) recorded = std::nextafter(recorded, std::numeric_limits<float>::infinity());
        errors_[where[k]] = recorded;
        max_error = std::max(max_error, double(recorded));
        pieces += std::uint64_t(out[k].quadrature_pieces);
    }
    slice_max_error_[slice] = max_error;
    slice_pieces_[slice] = pieces;
}

double ExactLutIntegrand::max_error() const {
    return slice_max_error_.empty() ? 0.0 : *std::max_element(slice_max_error_.begin(), slice_max_error_.end());
}

std::uint64_t ExactLutIntegrand::quadrature_pieces() const {
    std::uint64_t sum = 0;
    for (auto p : slice_pieces_) sum += p;
    return sum;
}

std::string ExactLutIntegrand::save_item(std::uint64_t slice) const {
    const std::uint32_t ivv = std::uint32_t(slice / channels_), channel = std::uint32_t(slice % channels_);
    const AtlasShape shape{spec_.visibility.count, spec_.n_dot_l.count, spec_.n_dot_v.count, channels_};
    std::vector<float> value, error;
    for (std::uint32_t il = 0; il < spec_.n_dot_l.count; ++il)
        for (std::uint32_t iv = 0; iv < spec_.visibility.count; ++iv) {
            value.push_back(values_[shape.index(channel, iv, il, ivv)]);
            error.push_back(errors_[shape.index(channel, iv, il, ivv)]);
        }
    schedule::ItemWriter w;
    w.put_vector(value);
    w.put_vector(error);
    w.put(slice_max_error_.at(slice));
    w.put(slice_pieces_.at(slice));
    return w.take();
}

void ExactLutIntegrand::load_item(std::uint64_t slice, const std::string& bytes) {
    if (slice >= work_items()) throw std::runtime_error("exact LUT slice " + std::to_string(slice) + ": no such slice");
    const std::uint32_t ivv = std::uint32_t(slice / channels_), channel = std::uint32_t(slice % channels_);
    const AtlasShape shape{spec_.visibility.count, spec_.n_dot_l.count, spec_.n_dot_v.count, channels_};
    schedule::ItemReader r(bytes, "exact LUT slice " + std::to_string(slice));
    const std::uint64_t texels = std::uint64_t(spec_.n_dot_l.count) * spec_.visibility.count;
    const std::vector<float> value = r.get_vector<float>(texels), error = r.get_vector<float>(texels);
    const double max_error = r.get<double>();
    const std::uint64_t pieces = r.get<std::uint64_t>();
    r.finish();
    if (const std::string problem = schedule::check_fraction_texels(value, error, spec_.n_dot_l.count, spec_.visibility.count,
                                                                    [&](std::uint32_t il) { return spec_.row_baked(slice, il); });
        !problem.empty())
        throw std::runtime_error("exact LUT slice " + std::to_string(slice) + ": " + problem);
    std::size_t k = 0;
    for (std::uint32_t il = 0; il < spec_.n_dot_l.count; ++il)
        for (std::uint32_t iv = 0; iv < spec_.visibility.count; ++iv, ++k) {
            values_[shape.index(channel, iv, il, ivv)] = value[k];
            errors_[shape.index(channel, iv, il, ivv)] = error[k];
        }
    slice_max_error_[slice] = max_error;
    slice_pieces_[slice] = pieces;
}

}  // namespace ms::exact_term

namespace ms::exact_term {

std::string ExactLutIntegrand::check_item(std::uint64_t slice, const std::string& bytes) const {
    if (slice >= work_items()) return "index: no slice " + std::to_string(slice);
    try {
        schedule::ItemReader r(bytes, "exact LUT slice " + std::to_string(slice));
        const std::uint64_t texels = std::uint64_t(spec_.n_dot_l.count) * spec_.visibility.count;
        const std::vector<float> value = r.get_vector<float>(texels), error = r.get_vector<float>(texels);
        const double max_error = r.get<double>();
        r.get<std::uint64_t>();
        r.finish();
        if (!(max_error >= 0) && !std::isnan(max_error)) return "values: the slice's largest error is " + std::to_string(max_error);
        return schedule::check_fraction_texels(value, error, spec_.n_dot_l.count, spec_.visibility.count,
                                               [&](std::uint32_t il) { return spec_.row_baked(slice, il); });
    } catch (const std::exception& e) {
        return std::string("payload: ") + e.what();
    }
}

}  // namespace ms::exact_term
