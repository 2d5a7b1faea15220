#include "jobs/tolerance_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "io/text.hpp"

namespace ms {

void ToleranceCheck::add(double error) {
    ++values;
    if (!(tolerance > 0) || error <= tolerance) return;
    ++over;
    worst = std::isnan(error) || std::isnan(worst) ? std::numeric_limits<double>::quiet_NaN() : std::max(worst, error);
}

std::string ToleranceCheck::summary() const {
    if (!(tolerance > 0)) return "";
    if (met()) return "(tolerance " + format_g(tolerance) + " met)";
    return "(TOLERANCE NOT MET: " + std::to_string(over) + " of " + std::to_string(values) + " above " + format_g(tolerance) +
           ", worst " + format_g(worst) + ")";
}

}  // namespace ms
