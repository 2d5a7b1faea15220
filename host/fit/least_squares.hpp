// Weighted linear least squares and Gauss-Newton for models that are a fixed function of a linear
// combination of basis functions: the fitting layer of the closed-form approximation.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

namespace ms::fit {

// A dense row-major design matrix: rows[i * columns + k] is basis function k at sample i.
struct Design {
    std::size_t columns = 0;
    std::vector<double> rows;
    std::size_t samples() const { return columns ? rows.size() / columns : 0; }
};

// argmin_c sum_i w_i (sum_k A_ik c_k - y_i)^2 by Householder QR of sqrt(w) A (no normal equations:
// their condition number is the square of A's, and polynomial bases are badly conditioned).
// Columns whose pivot is below `rank_tolerance` times the largest are set to 0 (a basis function the
// data cannot tell from the others). Throws std::invalid_argument on mismatched sizes or no weight.
std::vector<double> weighted_least_squares(const Design& a, const std::vector<double>& y, const std::vector<double>& w,
                                           double rank_tolerance = 1e-12);

// A model y ~ link(sum_k A_ik c_k): the link and its derivative.
struct Link {
    std::function<double(double)> value, derivative;
};

struct GaussNewtonReport {
    unsigned iterations = 0;
    double initial_cost = 0, final_cost = 0;  // sum_i w_i (y_i - link(A c)_i)^2
};

// Minimises sum_i w_i (y_i - link((A c)_i))^2 from `start` by Gauss-Newton steps with step halving
// (a step is accepted only if it lowers the cost), at most `iterations` steps, stopping when a step
// improves the cost by less than a relative 1e-9.
std::vector<double> gauss_newton(const Design& a, const std::vector<double>& y, const std::vector<double>& w,
                                 const Link& link, std::vector<double> start, unsigned iterations,
                                 GaussNewtonReport* report = nullptr);

}  // namespace ms::fit
