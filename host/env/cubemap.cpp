#include "env/cubemap.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace ms::env {

Cubemap::Cubemap(std::uint32_t n) : size(n) {
    for (auto& f : faces) f = Image(n, n, {"R", "G", "B"});
}

void cross_face_offset(int face, std::uint32_t n, std::uint32_t& x, std::uint32_t& y) {
    static const std::uint32_t ox[6] = {2, 0, 1, 1, 1, 3}, oy[6] = {1, 1, 0, 2, 1, 1};
    if (face < 0 || face > 5) throw std::invalid_argument("cross_face_offset: face 0..5");
    x = ox[face] * n;
    y = oy[face] * n;
}

namespace {

std::array<float, 3> equirect_bilinear(const Image& img, double u, double v) {
    const double x = u * img.width - 0.5, y = std::clamp(v * img.height - 0.5, 0.0, double(img.height - 1));
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    const long x0 = long(fx), y0 = long(fy);
    std::array<float, 3> out{};
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
            const long xi = ((x0 + i) % long(img.width) + long(img.width)) % long(img.width);
            const long yi = std::min<long>(y0 + j, long(img.height) - 1);
            const double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
            for (int c = 0; c < 3; ++c) out[c] += float(w * img.at(std::uint32_t(xi), std::uint32_t(yi), c));
        }
    return out;
}

// The texel of `cube` that holds direction d (nearest).
const float* nearest(const Cubemap& cube, const Dir& d) {
    int face;
    double s, t;
    cube_face_st(d, face, s, t);
    const std::uint32_t n = cube.size;
    const long x = std::clamp(long(std::floor((s + 1) * 0.5 * n)), 0L, long(n) - 1);
    const long y = std::clamp(long(std::floor((t + 1) * 0.5 * n)), 0L, long(n) - 1);
    return cube.texel(face, std::uint32_t(x), std::uint32_t(y));
}

}  // namespace

Cubemap cubemap_from_equirect(const Image& img, std::uint32_t size, std::uint32_t ss) {
    if (img.channels < 3) throw std::invalid_argument("cubemap_from_equirect: need RGB");
    Cubemap cube(size);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < size; ++y)
            for (std::uint32_t x = 0; x < size; ++x) {
                double acc[3] = {0, 0, 0};
                for (std::uint32_t j = 0; j < ss; ++j)
                    for (std::uint32_t i = 0; i < ss; ++i) {
                        const double s = 2 * (x + (i + 0.5) / ss) / size - 1, t = 2 * (y + (j + 0.5) / ss) / size - 1;
                        double u, v;
                        equirect_uv(cube_direction(f, s, t), u, v);
                        const auto c = equirect_bilinear(img, u, v);
                        for (int k = 0; k < 3; ++k) acc[k] += c[k];
                    }
                float* out = cube.texel(f, x, y);
                for (int k = 0; k < 3; ++k) out[k] = float(acc[k] / (ss * ss));
            }
    return cube;
}

Cubemap cubemap_from_cross(const Image& img) {
    const bool horizontal = img.width * 3 == img.height * 4, vertical = img.width * 4 == img.height * 3;
    if (!horizontal && !vertical) throw std::invalid_argument("not a 4:3 or 3:4 cross");
    const std::uint32_t n = horizontal ? img.width / 4 : img.width / 3;
    Cubemap cube(n);
    for (int f = 0; f < 6; ++f) {
        std::uint32_t ox, oy;
        bool rotate = false;
        if (horizontal) {
            cross_face_offset(f, n, ox, oy);
        } else {
            static const std::uint32_t vx[6] = {2, 0, 1, 1, 1, 1}, vy[6] = {1, 1, 0, 2, 1, 3};
            ox = vx[f] * n, oy = vy[f] * n;
            rotate = f == 5;
        }
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const std::uint32_t sx = rotate ? n - 1 - x : x, sy = rotate ? n - 1 - y : y;
                for (int c = 0; c < 3; ++c) cube.texel(f, x, y)[c] = img.at(ox + sx, oy + sy, c);
            }
    }
    return cube;
}

Cubemap cubemap_from_image(const Image& img, std::uint32_t size) {
    if (img.width == 2 * img.height) {
        if (size == 0) {
            size = 1;
            while (size * 2 <= img.height / 2) size *= 2;
        }
        return cubemap_from_equirect(img, size, 2);
    }
    if (img.width * 3 == img.height * 4 || img.width * 4 == img.height * 3) return cubemap_from_cross(img);
    throw std::invalid_argument("environment of " + std::to_string(img.width) + " x " + std::to_string(img.height) +
                                ": expected a 2:1 equirectangular image or a 4:3 / 3:4 cross");
}

Cubemap cubemap_from_faces(const std::vector<Image>& faces, const std::vector<std::string>& names) {
    static const char* const kFace[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    if (faces.size() != 6 || names.size() != 6)
        throw std::invalid_argument("a cubemap needs six face files (+X -X +Y -Y +Z -Z), got " + std::to_string(faces.size()));
    const std::uint32_t n = faces[0].width;
    for (int f = 0; f < 6; ++f) {
        const Image& img = faces[f];
        const std::string what = "face " + std::string(kFace[f]) + " (" + names[f] + ", " + std::to_string(img.width) + " x " +
                                 std::to_string(img.height) + ")";
        if (img.width != img.height) throw std::invalid_argument(what + ": a cubemap face must be square");
        if (img.width == 0) throw std::invalid_argument(what + ": empty image");
        if (img.width != n)
            throw std::invalid_argument(what + ": every face must have the size of +X (" + names[0] + ", " + std::to_string(n) + " x " +
                                        std::to_string(n) + ")");
        if (img.channels < 3) throw std::invalid_argument(what + ": need RGB");
    }
    Cubemap cube(n);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x)
                for (int c = 0; c < 3; ++c) cube.texel(f, x, y)[c] = faces[f].at(x, y, std::uint32_t(c));
    return cube;
}

Cubemap read_cubemap_faces(const std::vector<std::string>& paths) {
    if (paths.size() != 6)
        throw std::invalid_argument("--faces takes six files in the order +X -X +Y -Y +Z -Z, got " + std::to_string(paths.size()));
    std::vector<Image> faces;
    // All six are read before the checks so the message can name the first face that differs.
    static const char* const kFace[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    for (std::size_t f = 0; f < 6; ++f) {
        // A missing file is bad input (exit 2), not a read failure of an existing file.
        if (!std::filesystem::is_regular_file(paths[f]))
            throw std::invalid_argument("face " + std::string(kFace[f]) + ": " + paths[f] + " does not exist or is not a file");
        faces.push_back(read_environment_image(paths[f]));
    }
    return cubemap_from_faces(faces, paths);
}

std::vector<Cubemap> mip_chain(const Cubemap& base) {
    if (base.size == 0 || (base.size & (base.size - 1))) throw std::invalid_argument("mip_chain: face size must be a power of two");
    std::vector<Cubemap> chain{base};
    while (chain.back().size > 1) {
        const Cubemap& src = chain.back();
        Cubemap dst(src.size / 2);
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < dst.size; ++y)
                for (std::uint32_t x = 0; x < dst.size; ++x)
                    for (int c = 0; c < 3; ++c)
                        dst.texel(f, x, y)[c] = 0.25f * (src.texel(f, 2 * x, 2 * y)[c] + src.texel(f, 2 * x + 1, 2 * y)[c] +
                                                         src.texel(f, 2 * x, 2 * y + 1)[c] + src.texel(f, 2 * x + 1, 2 * y + 1)[c]);
        chain.push_back(std::move(dst));
    }
    return chain;
}

std::array<float, 3> sample_bilinear(const Cubemap& cube, const Dir& d) {
    int face;
    double s, t;
    cube_face_st(d, face, s, t);
    const std::uint32_t n = cube.size;
    const double x = (s + 1) * 0.5 * n - 0.5, y = (t + 1) * 0.5 * n - 0.5;
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    const long x0 = long(fx), y0 = long(fy);
    std::array<float, 3> out{};
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
            const double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
            if (w == 0) continue;
            const long xi = x0 + i, yi = y0 + j;
            const float* p;
            if (xi >= 0 && yi >= 0 && xi < long(n) && yi < long(n)) {
                p = cube.texel(face, std::uint32_t(xi), std::uint32_t(yi));
            } else {
                // Beyond the edge: the neighbouring face's texel through the texel centre's direction.
                p = nearest(cube, cube_direction(face, 2 * (xi + 0.5) / n - 1, 2 * (yi + 0.5) / n - 1));
            }
            for (int c = 0; c < 3; ++c) out[c] += float(w * p[c]);
        }
    return out;
}

std::array<float, 3> sample_trilinear(const std::vector<Cubemap>& chain, const Dir& d, double lod) {
    lod = std::clamp(lod, 0.0, double(chain.size() - 1));
    const std::size_t l0 = std::size_t(std::floor(lod));
    const double f = lod - double(l0);
    auto a = sample_bilinear(chain[l0], d);
    if (f > 0 && l0 + 1 < chain.size()) {
        const auto b = sample_bilinear(chain[l0 + 1], d);
        for (int c = 0; c < 3; ++c) a[c] = float((1 - f) * a[c] + f * b[c]);
    }
    return a;
}

Image cross_image(const Cubemap& cube) {
    const std::uint32_t n = cube.size;
    Image img(4 * n, 3 * n, {"R", "G", "B"});
    for (int f = 0; f < 6; ++f) {
        std::uint32_t ox, oy;
        cross_face_offset(f, n, ox, oy);
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x)
                for (int c = 0; c < 3; ++c) img.at(ox + x, oy + y, c) = cube.texel(f, x, y)[c];
    }
    return img;
}

}  // namespace ms::env
