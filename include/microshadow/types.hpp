// microshadow's public types: methods, backends, queries, estimates and sampling options
// (included by <microshadow/microshadow.hpp>).
#pragma once

#include <cstdint>
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

// Where and how to sample; shared by evaluate() and bake().
struct SamplingOptions {
    Method method = Method::sampled;
    Backend backend = Backend::opencl;
    std::string device = "default";  // OpenCL: "default", "all", an index or a name fragment
    std::uint64_t samples = 65536;   // per query (evaluate) or per batch and LUT slice (bake); rounded up
                                     // to replicates x a power of two
    std::uint32_t replicates = 8;    // independent randomisations: where the standard error comes from
    std::uint64_t seed = 0;
    AoWeighting ao_weighting = AoWeighting::cosine;
    Form form = Form::height_correlated;
    // exact only: the estimated absolute error asked of each value (0: 1e-10 for evaluate, 1e-6 for bake).
    double tolerance = 0;
};

}  // namespace microshadow
