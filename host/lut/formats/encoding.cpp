#include "lut/formats/encoding.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace ms::lutfmt {

std::string to_string(PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return "float32";
        case PixelEncoding::float16: return "float16";
        case PixelEncoding::unorm8: return "unorm8";
        case PixelEncoding::unorm16: return "unorm16";
    }
    return "?";
}

PixelEncoding parse_pixel_encoding(const std::string& s) {
    if (s == "float32" || s == "float") return PixelEncoding::float32;
    if (s == "float16" || s == "half") return PixelEncoding::float16;
    if (s == "unorm8" || s == "rgba8") return PixelEncoding::unorm8;
    if (s == "unorm16" || s == "rgba16") return PixelEncoding::unorm16;
    throw std::invalid_argument("--encoding must be float32, float16, unorm8 or unorm16, not '" + s + "'");
}

std::uint32_t bytes_per_component(PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return 4;
        case PixelEncoding::float16: return 2;
        case PixelEncoding::unorm8: return 1;
        case PixelEncoding::unorm16: return 2;
    }
    return 0;
}

std::uint16_t float_to_half(float v) {
    std::uint32_t x;
    std::memcpy(&x, &v, 4);
    const std::uint32_t sign = (x >> 16) & 0x8000u;
    const std::uint32_t a = x & 0x7fffffffu;
    if (a >= 0x7f800000u)  // infinity stays infinity; NaN keeps its top payload bits and stays quiet
        return std::uint16_t(sign | 0x7c00u | (a > 0x7f800000u ? 0x200u | ((a >> 13) & 0x3ffu) : 0u));
    // 65520 = 0x477ff000 is halfway between the largest half (65504, odd significand) and 2^16: ties
    // to even go up, so everything from there on overflows to infinity.
    if (a >= 0x477ff000u) return std::uint16_t(sign | 0x7c00u);
    if (a < 0x38800000u) {  // below 2^-14, the smallest normal half: a subnormal (units of 2^-24) or 0
        if (a < 0x33000000u) return std::uint16_t(sign);  // < 2^-25 rounds to 0 (2^-25 itself ties to even 0)
        const std::uint32_t e = a >> 23, m = (a & 0x7fffffu) | 0x800000u;
        const std::uint32_t shift = 126u - e;  // value / 2^-24 = m >> shift, shift in [14, 24]
        std::uint32_t h = m >> shift;
        const std::uint32_t rem = m & ((1u << shift) - 1u), halfway = 1u << (shift - 1u);
        if (rem > halfway || (rem == halfway && (h & 1u))) ++h;  // may round up to the smallest normal: right
        return std::uint16_t(sign | h);
    }
    // Normal: rebias the exponent (127 -> 15, i.e. subtract 112 << 23) and drop 13 significand bits.
    std::uint32_t h = (a - 0x38000000u) >> 13;
    const std::uint32_t rem = a & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1u))) ++h;  // a carry into the exponent is the right result
    return std::uint16_t(sign | h);
}

float half_to_float(std::uint16_t h) {
    const std::uint32_t sign = std::uint32_t(h & 0x8000u) << 16;
    const std::uint32_t e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
    float f;
    if (e == 0) {
        f = std::ldexp(float(m), -24);  // subnormal (or zero): m units of 2^-24, exact in float
        std::uint32_t x;
        std::memcpy(&x, &f, 4);
        x |= sign;
        std::memcpy(&f, &x, 4);
        return f;
    }
    const std::uint32_t x = sign | (e == 31 ? (0xffu << 23) | (m << 13) : ((e + 112u) << 23) | (m << 13));
    std::memcpy(&f, &x, 4);
    return f;
}

std::uint32_t to_unorm(float v, unsigned bits) {
    const double scale = double((1u << bits) - 1u);
    const double c = std::isnan(v) ? 0.0 : std::clamp(double(v), 0.0, 1.0);
    return std::uint32_t(std::lround(c * scale));  // round half away from zero: never a tie in practice
}

double float32_rounding_bound(const std::vector<float>& data) {
    // A value computed in double and rounded to the nearest float v is within half the spacing of floats
    // at v (the spacing above v, the larger one at a power of 2).
    double worst = 0;
    for (float v : data)
        if (std::isfinite(v)) worst = std::max(worst, 0.5 * (double(std::nextafter(std::fabs(v), INFINITY)) - std::fabs(double(v))));
    return worst;
}

double quantisation_error(const std::vector<float>& data, PixelEncoding encoding) {
    // Every encoding stores values that were first rounded to float32; the narrower ones round again.
    const double float32 = float32_rounding_bound(data);
    switch (encoding) {
        case PixelEncoding::float32: return float32;
        case PixelEncoding::float16: {
            double worst = 0;
            for (float v : data) worst = std::max(worst, std::abs(double(half_to_float(float_to_half(v))) - double(v)));
            return float32 + worst;
        }
        case PixelEncoding::unorm8: return float32 + 0.5 / 255.0;
        case PixelEncoding::unorm16: return float32 + 0.5 / 65535.0;
    }
    return float32;
}

std::string quantisation_kind(PixelEncoding encoding) {
    const std::string float32 = "the computed values' rounding to float32 (half the float spacing at the largest |value|)";
    switch (encoding) {
        case PixelEncoding::float32: return float32;
        case PixelEncoding::float16: return float32 + " + float16 round to nearest even: measured max |half(v) - v| over the data";
        case PixelEncoding::unorm8: return float32 + " + unorm8 round(v * 255): bound 0.5 / 255";
        case PixelEncoding::unorm16: return float32 + " + unorm16 round(v * 65535): bound 0.5 / 65535";
    }
    return "?";
}

void add_error_budget(nlohmann::json& meta, const std::vector<float>& data, PixelEncoding encoding) {
    // Absent fields count 0 (a fixed-azimuth bake has no quadrature error), but a present field must be
    // a number: a string there would silently drop a term.
    auto term = [&](const char* key) {
        if (!meta.contains(key)) return 0.0;
        if (!meta.at(key).is_number()) throw std::invalid_argument(std::string("metadata field ") + key + " is not a number");
        return meta.at(key).get<double>();
    };
    const double sampling = term("max_error"), azimuth = term("azimuth_quadrature_error");
    // A LUT exported from a quantised file (lut export) keeps the rounding it already went through.
    const double earlier = term("earlier_quantisation_error");
    const double quant = quantisation_error(data, encoding);
    const double total = sampling + azimuth + earlier + quant;
    meta["encoding"] = to_string(encoding);
    meta["error_budget"] = {{"sampling", sampling},
                            {"sampling_kind", "max_error: largest per-texel replicate standard error"},
                            {"azimuth_quadrature", azimuth},
                            {"azimuth_quadrature_kind", "azimuth_quadrature_error: max |T_K/2 - T_K| over rows"},
                            {"quantisation", quant},
                            {"quantisation_kind", quantisation_kind(encoding)},
                            {"total", total}};
    if (meta.contains("earlier_quantisation_error")) meta["error_budget"]["earlier_quantisation"] = earlier;
    meta["max_total_error"] = total;
}

void check_lut_shape(const LutFile& lut) {
    if (lut.axes.size() != 3) throw std::invalid_argument("LUT: need the visibility, n_dot_l and n_dot_v axes");
    if (lut.channels.empty() || lut.channels.size() > 4) throw std::invalid_argument("LUT: 1 to 4 channels");
    const std::uint64_t w = lut.axes[0].count, h = std::uint64_t(lut.axes[1].count) * lut.axes[2].count;
    if (w == 0 || h == 0 || lut.width != w || lut.height != h || lut.data.size() != w * h * lut.channels.size())
        throw std::invalid_argument("LUT: image size and data do not match the axes");
}

std::vector<float> rgba_padded(const LutFile& lut) {
    const std::size_t nc = lut.channels.size(), n = std::size_t(lut.width) * lut.height;
    std::vector<float> out(n * 4);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t c = 0; c < 4; ++c) out[i * 4 + c] = lut.data[i * nc + std::min(c, nc - 1)];
    return out;
}

void add_padding_note(nlohmann::json& meta, const LutFile& lut) {
    const char* names[4] = {"R", "G", "B", "A"};
    meta["texture_channels"] = 4;
    nlohmann::json padded = nlohmann::json::array();
    for (std::size_t c = lut.channels.size(); c < 4; ++c) padded.push_back(names[c]);
    meta["padded_channels"] = padded;
    if (!padded.empty())
        meta["padding"] = std::string("channels ") + padded.dump() + " repeat channel " + names[lut.channels.size() - 1] +
                          " (the highest-index roughness channel); read only the first " +
                          std::to_string(lut.channels.size());
}

void append_encoded(std::vector<std::uint8_t>& out, const std::vector<float>& rgba, PixelEncoding encoding) {
    auto put = [&](std::uint32_t v, unsigned bytes) {
        for (unsigned b = 0; b < bytes; ++b) out.push_back(std::uint8_t(v >> (8 * b)));
    };
    out.reserve(out.size() + rgba.size() * bytes_per_component(encoding));
    for (float v : rgba) {
        switch (encoding) {
            case PixelEncoding::float32: {
                std::uint32_t x;
                std::memcpy(&x, &v, 4);
                put(x, 4);
                break;
            }
            case PixelEncoding::float16: put(float_to_half(v), 2); break;
            case PixelEncoding::unorm8: put(to_unorm(v, 8), 1); break;
            case PixelEncoding::unorm16: put(to_unorm(v, 16), 2); break;
        }
    }
}

nlohmann::json format_metadata(const LutFile& lut, PixelEncoding encoding, const std::string& format, bool padded_rgba) {
    check_lut_shape(lut);
    nlohmann::json meta = lut.metadata.is_object() ? lut.metadata : nlohmann::json::object();
    meta["axes"] = nlohmann::json::array();
    for (const auto& a : lut.axes)
        meta["axes"].push_back({{"name", a.name}, {"min", a.min}, {"max", a.max}, {"count", a.count}, {"texel", to_string(a.texel)}});
    const char* names[4] = {"R", "G", "B", "A"};
    meta["channels"] = nlohmann::json::array();
    for (std::size_t c = 0; c < lut.channels.size(); ++c) {
        const auto& ch = lut.channels[c];
        meta["channels"].push_back({{"name", ch.name}, {"texture_channel", names[c]}, {"roughness", ch.roughness},
                                    {"alpha_x", ch.alpha_x}, {"alpha_y", ch.alpha_y}});
    }
    meta["file_format"] = format;
    if (padded_rgba) add_padding_note(meta, lut);
    add_error_budget(meta, lut.data, encoding);
    return meta;
}

}  // namespace ms::lutfmt
