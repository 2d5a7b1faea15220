// Core value types of microshadow: queries, options and estimates. Plain data, no formulas.
#pragma once

#include <cstdint>
#include <string>

namespace ms {

inline constexpr double kPi = 3.14159265358979323846;

// How the AO bake that produced the visibility weighted its rays (part 1): it decides the cone.
enum class AoWeighting { cosine, uniform };
// Smith form of the weight G2(wi,wo,wm) / G1(wi,wm) (part 2).
enum class Form { height_correlated, uncorrelated };
// Point sequence fed to the VNDF sampler.
enum class Sequence { sobol, random };
// How the term is integrated: by VNDF sampling (RQMC estimate, replicate standard error) or by the
// deterministic boundary-integral evaluator of host/exact/ (quadrature, error estimate from a
// higher-order rule).
enum class Method { sampled, exact };

struct Vec3 {
    double x = 0, y = 0, z = 0;
};

// One evaluation of GenericM_g. wi (view, V) is the direction the VNDF is sampled from, wo (light, L)
// the shadowed direction; both unit vectors in the tangent frame, normal = +z.
struct Query {
    double visibility = 1;
    double alpha_x = 0.5;
    double alpha_y = 0.5;
    Vec3 wi{0, 0, 1};
    Vec3 wo{0, 0, 1};
};

// A Monte Carlo / RQMC estimate with its standard error (0 when the value is exact).
struct Estimate {
    double term = 0;
    double std_error = 0;
};

// How an estimate is sampled. samples = replicates * points_per_replicate; each replicate is an
// independent randomisation of the sequence, which is where the standard error comes from.
//
// method = exact replaces sampling by the deterministic evaluator (host/exact/): the four sampling fields
// are then unused, and `tolerance` is the estimated absolute error asked of each value (the Estimate's
// std_error is then that estimate, not a replicate spread).
struct SamplingPlan {
    Sequence sequence = Sequence::sobol;
    std::uint64_t samples = 65536;
    std::uint32_t replicates = 8;
    std::uint64_t seed = 0;
    Method method = Method::sampled;
    // Estimated absolute error asked of each value; 0: the method's default (exact: 1e-10; sampled: one
    // pass of `samples`). Sampled runs with a tolerance quadruple the samples of the values above it.
    double tolerance = 0;
    bool single_precision = false;       // exact method on OpenCL devices: the float kernel even with fp64
    bool kernel_on_cpu_devices = false;  // exact method: the kernel on CPU devices too (default: the C++ evaluator)
};

struct TermOptions {
    Form form = Form::height_correlated;
    AoWeighting ao_weighting = AoWeighting::cosine;
};

std::string to_string(AoWeighting);
std::string to_string(Form);
std::string to_string(Sequence);
std::string to_string(Method);
// Parse the CLI spellings ("cosine", "height-correlated", "sobol", ...); throw std::invalid_argument.
AoWeighting parse_ao_weighting(const std::string&);
Form parse_form(const std::string&);
Sequence parse_sequence(const std::string&);
Method parse_method(const std::string&);

}  // namespace ms
