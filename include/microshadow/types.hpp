// microshadow's public types: methods, backends, queries, estimates and sampling options
// (included by <microshadow/microshadow.hpp>).
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

namespace microshadow {

// How the term is integrated. sampled: randomised quasi-Monte Carlo VNDF sampling, an estimate with
// its replicate standard error. exact: the deterministic boundary-integral evaluator, a value with its
// estimated quadrature error (to SamplingOptions::tolerance).
enum class Method { sampled, exact };
// The ambient-occlusion cone's weighting of the visibility v (cosine: the cone's half angle has
// cos = sqrt(1 - v); uniform: cos = 1 - v).
enum class AoWeighting { cosine, uniform };
// The Smith form of the masking-shadowing weight.
enum class Form { height_correlated, uncorrelated };
// Where the work runs: OpenCL devices, or the scalar double-precision oracle on the CPU threads
// (no OpenCL needed; slower, for checks and small jobs).
enum class Backend { opencl, oracle };
// The sampled method's point sets: scrambled Sobol' nets (randomised quasi-Monte Carlo) or
// independent uniform random points.
enum class Sequence { sobol, random };

// Perceptual roughness r in (0, 1], GGX alpha = r^2: what the LUTs, the representations and the
// analytic terms are indexed by. A type of its own so that an alpha can never be passed where a
// roughness is meant (alpha 0.3 is roughness 0.548): write Roughness(0.5), or Roughness::from_alpha(a).
// Every isotropic call takes its parameters in one order: visibility, NdotL, NdotV, roughness and then
// the relative azimuth (the LUT's axes, then its channels).
struct Roughness {
    constexpr explicit Roughness(double perceptual) : value(perceptual) {}
    // The roughness of a GGX alpha: sqrt(alpha).
    static Roughness from_alpha(double alpha);
    constexpr double alpha() const { return value * value; }
    double value;
};

struct Direction {
    double x = 0, y = 0, z = 1;
};

// One evaluation of the term: visibility v in [0, 1], GGX roughness alpha_x, alpha_y (> 0), and the
// view wi and light wo directions in the tangent frame (normal = +z; normalised by the library).
struct Query {
    double visibility = 1;
    double alpha_x = 0.25, alpha_y = 0.25;
    Direction wi{0, 0, 1}, wo{0, 0, 1};
};

// The term and its standard error (0 where the value is exact: visibility 1, the zero region).
struct Estimate {
    double value = 0;
    double std_error = 0;
};

// Where and how to sample; shared by evaluate() and bake(). The method defaults to each call's command:
// exact for evaluate() (as `microshadow eval`), sampled for bake() and area_evaluate() (BakeOptions and
// AreaOptions set it), exact for repr_bake().
struct SamplingOptions {
    Method method = Method::exact;
    Backend backend = Backend::opencl;
    std::string device = "default";  // OpenCL: "default", "all", an index or a name fragment
    std::uint64_t samples = 65536;   // per query (evaluate) or per batch and LUT slice (bake); rounded up
                                     // to replicates x a power of two
    std::uint32_t replicates = 8;    // independent randomisations: where the standard error comes from
    std::uint64_t seed = 0;
    AoWeighting ao_weighting = AoWeighting::cosine;
    Form form = Form::height_correlated;
    // The estimated absolute error asked of each value. exact: the quadrature's estimate (0: 1e-10 for
    // evaluate, 1e-9 for repr_bake, 1e-6 for bake). sampled evaluate: the replicate standard error, reached by quadrupling the
    // samples of the queries above it (0: one pass of `samples`); sampled bake: BakeOptions::tolerance.
    double tolerance = 0;
    Sequence sequence = Sequence::sobol;  // sampled only
    bool fast_math = false;               // OpenCL kernels built with -cl-fast-relaxed-math
    bool exact_float = false;             // exact on OpenCL: the float kernel even where the device has fp64
};

// Told of a long call's progress: (done, total) in the call's own units (queries, slices, texels,
// chunks). Return false to stop the call: it then throws Cancelled and returns nothing. Called from the
// thread that made the call or from one of the call's worker threads (so it must be safe to call from
// another thread than yours); keep it short.
using Progress = std::function<bool(std::uint64_t done, std::uint64_t total)>;

// Thrown by a call whose Progress asked it to stop. Nothing was written.
class Cancelled : public std::runtime_error {
public:
    Cancelled() : std::runtime_error("interrupted; nothing was written") {}
    explicit Cancelled(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace microshadow
