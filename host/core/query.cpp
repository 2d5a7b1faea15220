#include "core/query.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <stdexcept>

namespace ms {

namespace {
std::string format_short(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}
double length(const Vec3& v) { return std::hypot(v.x, v.y, v.z); }
bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

void validate_query(const Query& q) {
    if (!std::isfinite(q.visibility) || q.visibility < 0 || q.visibility > 1)
        throw std::invalid_argument("visibility must be in [0, 1]");
    if (!std::isfinite(q.alpha_x) || !(q.alpha_x > 0)) throw std::invalid_argument("alpha_x must be a finite number > 0");
    if (!std::isfinite(q.alpha_y) || !(q.alpha_y > 0)) throw std::invalid_argument("alpha_y must be a finite number > 0");
    if (!finite(q.wi) || !(length(q.wi) > 0) || !std::isfinite(length(q.wi)))
        throw std::invalid_argument("wi must be a finite non-zero vector");
    if (!finite(q.wo) || !(length(q.wo) > 0) || !std::isfinite(length(q.wo)))
        throw std::invalid_argument("wo must be a finite non-zero vector");
    if (!(q.wi.z / length(q.wi) > 0)) throw std::invalid_argument("wi must be above the horizon (wi_z > 0)");
}

void validate_exact_query(const Query& q) {
    validate_query(q);
    const double lo = std::min(q.alpha_x, q.alpha_y), hi = std::max(q.alpha_x, q.alpha_y);
    if (lo < kExactMinAlpha)
        throw std::invalid_argument("alpha " + format_short(lo) + " is below the exact method's smallest alpha " +
                                    format_short(kExactMinAlpha) + " (its integrals underflow); use --method sampled");
    if (hi / lo > kExactMaxAnisotropy)
        throw std::invalid_argument("alpha_x / alpha_y = " + format_short(q.alpha_x / q.alpha_y) +
                                    ": the exact method holds up to an anisotropy of " + format_short(kExactMaxAnisotropy) +
                                    " (max alpha / min alpha); use --method sampled");
}

Query normalised(const Query& q) {
    Query out = q;
    const double li = length(q.wi), lo = length(q.wo);
    out.wi = {q.wi.x / li, q.wi.y / li, q.wi.z / li};
    out.wo = {q.wo.x / lo, q.wo.y / lo, q.wo.z / lo};
    return out;
}

}  // namespace ms
