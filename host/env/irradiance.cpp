#include "env/irradiance.hpp"

#include <cmath>
#include <stdexcept>

namespace ms::env {

namespace {

struct FaceFrame {
    Dir s, t, w;  // direction = normalize(s * e_s + t * e_t + e_w), as env/sphere.hpp's cube_direction
};
FaceFrame face_frame(int face) {
    switch (face) {
        case 0: return {{0, 0, -1}, {0, -1, 0}, {1, 0, 0}};
        case 1: return {{0, 0, 1}, {0, -1, 0}, {-1, 0, 0}};
        case 2: return {{1, 0, 0}, {0, 0, 1}, {0, 1, 0}};
        case 3: return {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}};
        case 4: return {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
        case 5: return {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    }
    throw std::invalid_argument("face must be 0..5");
}
double dot(const Dir& a, const Dir& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// The three corner functions of the rectangle integrals (see the header): integral of s / q^2, t / q^2 and
// 1 / q^2 over [0, s] x [0, t] up to terms that cancel in the four-corner difference.
double corner_s(double s, double t) {  // d2/ds dt of it = s / q^2
    const double k = std::sqrt(1 + s * s);
    return -0.5 * std::atan(t / k) / k;
}
double corner_t(double s, double t) { return corner_s(t, s); }
double corner_1(double s, double t) {
    const double ks = std::sqrt(1 + s * s), kt = std::sqrt(1 + t * t);
    return 0.5 * (s / ks * std::atan(t / ks) + t / kt * std::atan(s / kt));
}

// Green's theorem integrand along an edge: G dt - H ds.
double green(double a, double b, double w, double s, double t, double ds, double dt) {
    const double q = 1 + s * s + t * t, k2 = 1 + t * t, k = std::sqrt(k2);
    const double g = -a / (2 * q) + w * (s / (2 * k2 * q) + std::atan(s / k) / (2 * k2 * k));
    const double h = -b / (2 * q);
    return g * dt - h * ds;
}

// 8-point Gauss-Legendre on [0, 1].
constexpr double kGlX[8] = {0.019855071751231856, 0.10166676129318664, 0.23723379504183550, 0.40828267875217511,
                            0.59171732124782489,  0.76276620495816450, 0.89833323870681336, 0.98014492824876814};
constexpr double kGlW[8] = {0.050614268145188130, 0.11119051722668724, 0.15685332293894364, 0.18134189168918100,
                            0.18134189168918100,  0.15685332293894364, 0.11119051722668724, 0.050614268145188130};

}  // namespace

double clamped_cosine_texel_integral(const Dir& n, int face, std::uint32_t x, std::uint32_t y, std::uint32_t size) {
    const FaceFrame fr = face_frame(face);
    const double a = dot(n, fr.s), b = dot(n, fr.t), w = dot(n, fr.w);
    const double s0 = 2.0 * x / size - 1, s1 = 2.0 * (x + 1) / size - 1, t0 = 2.0 * y / size - 1, t1 = 2.0 * (y + 1) / size - 1;
    // Counter-clockwise in the (s, t) plane, the orientation Green's theorem takes.
    const double cs[4] = {s0, s1, s1, s0}, ct[4] = {t0, t0, t1, t1};
    double side[4];
    int above = 0;
    for (int i = 0; i < 4; ++i) {
        side[i] = a * cs[i] + b * ct[i] + w;  // the sign of n.l at the corner (the face plane has |p| > 0)
        above += side[i] >= 0;
    }
    if (above == 0) return 0;  // n.l <= 0 on the whole (convex) texel
    if (above == 4) {
        auto rect = [&](double (*f)(double, double)) { return f(s1, t1) - f(s0, t1) - f(s1, t0) + f(s0, t0); };
        return a * rect(corner_s) + b * rect(corner_t) + w * rect(corner_1);
    }
    // Clip the rectangle to a s + b t + w >= 0 (Sutherland-Hodgman, one line): at most five vertices.
    double ps[6], pt[6];
    int m = 0;
    for (int i = 0; i < 4; ++i) {
        const int j = (i + 1) % 4;
        if (side[i] >= 0) ps[m] = cs[i], pt[m] = ct[i], ++m;
        if ((side[i] >= 0) != (side[j] >= 0)) {
            const double f = side[i] / (side[i] - side[j]);
            ps[m] = cs[i] + f * (cs[j] - cs[i]), pt[m] = ct[i] + f * (ct[j] - ct[i]), ++m;
        }
    }
    double sum = 0;
    for (int i = 0; i < m; ++i) {
        const int j = (i + 1) % m;
        const double ds = ps[j] - ps[i], dt = pt[j] - pt[i];
        for (int g = 0; g < 8; ++g) sum += kGlW[g] * green(a, b, w, ps[i] + kGlX[g] * ds, pt[i] + kGlX[g] * dt, ds, dt);
    }
    return sum;
}

std::array<double, 3> irradiance_exact(const Cubemap& src, const Dir& n) {
    std::array<double, 3> e{};
    const std::uint32_t size = src.size;
    // A texel lies within 1.5 / size radians of its centre's direction (half its diagonal at a face's centre
    // is sqrt(2) / size); texels whose centre is further than that below the horizon contribute nothing.
    const double skip = -std::sin(std::min(1.5, 1.5 / size));
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < size; ++y)
            for (std::uint32_t x = 0; x < size; ++x) {
                const Dir c = cube_direction(f, 2 * (x + 0.5) / size - 1, 2 * (y + 0.5) / size - 1);
                if (dot(n, c) < skip) continue;
                const double k = clamped_cosine_texel_integral(n, f, x, y, size);
                const float* v = src.texel(f, x, y);
                for (int ch = 0; ch < 3; ++ch) e[ch] += v[ch] * k;
            }
    return e;
}

ReducedCubemap reduce_cubemap(const Cubemap& src, std::uint32_t size) {
    if (size == 0 || src.size % size != 0 || ((src.size / size) & (src.size / size - 1)))
        throw std::invalid_argument("reduce_cubemap: " + std::to_string(size) + " must divide the face size " + std::to_string(src.size) +
                                    " by a power of two");
    const std::uint32_t k = src.size / size;
    ReducedCubemap r{Cubemap(size), std::vector<std::array<double, 3>>(6u * size * size)};
    std::vector<double> omega(std::size_t(src.size) * src.size);
    for (std::uint32_t y = 0; y < src.size; ++y)
        for (std::uint32_t x = 0; x < src.size; ++x) omega[std::size_t(y) * src.size + x] = cube_texel_solid_angle(x, y, src.size);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < size; ++y)
            for (std::uint32_t x = 0; x < size; ++x) {
                double sum[3] = {0, 0, 0}, area = 0;
                for (std::uint32_t j = y * k; j < (y + 1) * k; ++j)
                    for (std::uint32_t i = x * k; i < (x + 1) * k; ++i) {
                        const double o = omega[std::size_t(j) * src.size + i];
                        area += o;
                        for (int c = 0; c < 3; ++c) sum[c] += src.texel(f, i, j)[c] * o;
                    }
                float* out = r.mean.texel(f, x, y);
                for (int c = 0; c < 3; ++c) out[c] = float(sum[c] / area);
                // The spread about the mean as stored (float): the bound's split then leaves only c_T times the
                // mean's rounding (2^-24 relative), which the kernel's rounding allowance covers.
                std::array<double, 3>& dev = r.deviation[(std::size_t(f) * size + y) * size + x];
                for (std::uint32_t j = y * k; j < (y + 1) * k; ++j)
                    for (std::uint32_t i = x * k; i < (x + 1) * k; ++i) {
                        const double o = omega[std::size_t(j) * src.size + i];
                        for (int c = 0; c < 3; ++c) dev[c] += std::abs(double(src.texel(f, i, j)[c]) - double(out[c])) * o;
                    }
            }
    return r;
}

}  // namespace ms::env
