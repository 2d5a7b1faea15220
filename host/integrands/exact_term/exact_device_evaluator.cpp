// The exact method on an OpenCL device: the kernels of kernels/exact/exact_term.cl through ExactKernel.
#include <algorithm>
#include <cmath>

#include "integrands/exact_term/exact_term_integrand.hpp"

namespace ms::exact_term {

namespace {

class DeviceEvaluator final : public Evaluator {
public:
    DeviceEvaluator(ocl::Device& device, const ocl::BuildConfig& build) : kernel_(device, build) {}

    void terms(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting, double tolerance,
               std::vector<exact::ExactValue>& out) override {
        out.resize(queries.size());
        // One launch per AO weighting present (the kernel takes one); results go back in query order.
        for (AoWeighting w : {AoWeighting::cosine, AoWeighting::uniform}) {
            std::vector<Query> part;
            std::vector<std::size_t> where;
            for (std::size_t i = 0; i < queries.size(); ++i)
                if (weighting[i] == w) {
                    part.push_back(queries[i]);
                    where.push_back(i);
                }
            if (part.empty()) continue;
            std::vector<exact::ExactValue> values;
            kernel_.terms(part, w, tolerance, values);
            for (std::size_t k = 0; k < where.size(); ++k) out[where[k]] = values[k];
        }
    }

    void texels(const std::vector<ExactTexel>& texels, AoWeighting weighting, bool azimuth_mean, double azimuth,
                double tolerance, std::vector<exact::ExactValue>& out) override {
        if (azimuth_mean) {
            kernel_.azimuth_means(texels, weighting, tolerance, out);
            return;
        }
        // A fixed azimuth is a plain query: wi in the xz-plane, wo rotated by the azimuth.
        std::vector<Query> queries(texels.size());
        for (std::size_t i = 0; i < texels.size(); ++i) {
            const ExactTexel& t = texels[i];
            Query& q = queries[i];
            q.visibility = t.visibility;
            q.alpha_x = q.alpha_y = t.alpha;
            q.wi = {std::sqrt(std::max(0.0, 1 - t.n_dot_v * t.n_dot_v)), 0, t.n_dot_v};
            const double sl = std::sqrt(std::max(0.0, 1 - t.n_dot_l * t.n_dot_l));
            q.wo = {sl * std::cos(azimuth), sl * std::sin(azimuth), t.n_dot_l};
        }
        kernel_.terms(queries, weighting, tolerance, out);
    }

private:
    exact::ExactKernel kernel_;
};

}  // namespace

std::unique_ptr<Evaluator> make_device_evaluator(ocl::Device& device, const ocl::BuildConfig& build) {
    return std::make_unique<DeviceEvaluator>(device, build);
}

}  // namespace ms::exact_term
