#include "env/image.hpp"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <Imath/half.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/exr_file.hpp"
#include "io/exr_preflight.hpp"

namespace ms::env {

void write_exr(const std::string& path, const Image& image, const nlohmann::json& metadata, bool half) {
    if (image.width == 0 || image.height == 0 || image.channels == 0 ||
        image.data.size() != std::size_t(image.width) * image.height * image.channels ||
        image.channel_names.size() != image.channels)
        throw std::invalid_argument("write_exr: inconsistent image");
    Imf::Header header = exr::image_header(image.width, image.height, image.channel_names, half);
    exr::insert_metadata(header, metadata);
    exr::write_interleaved(path, header, image.channel_names, image.data, image.channels, half);
}

Image read_exr_rgb(const std::string& path, nlohmann::json* metadata) {
    try {
        exr::preflight_image(path);  // claims the file cannot hold are refused before OpenEXR allocates them
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        if (metadata) {
            const auto* attr = header.findTypedAttribute<Imf::StringAttribute>("microshadow");
            *metadata = attr ? nlohmann::json::parse(attr->value()) : nlohmann::json::object();
        }
        const Imath::Box2i dw = header.dataWindow();
        const std::size_t w = std::size_t(dw.max.x - dw.min.x + 1), h = std::size_t(dw.max.y - dw.min.y + 1);
        if (w == 0 || h == 0 || w > 65536 || h > 65536) throw std::runtime_error("bad data window");
        Image image(std::uint32_t(w), std::uint32_t(h), {"R", "G", "B"});
        const bool grey = !header.channels().findChannel("R") && header.channels().findChannel("Y");
        Imf::FrameBuffer fb;
        const std::size_t stride = 3 * sizeof(float);
        char* base = (char*)image.data.data() - (std::ptrdiff_t(dw.min.x) * stride + std::ptrdiff_t(dw.min.y) * stride * w);
        if (grey) {
            fb.insert("Y", Imf::Slice(Imf::FLOAT, base, stride, stride * w, 1, 1, 0.0));
        } else {
            const char* names[3] = {"R", "G", "B"};
            for (int c = 0; c < 3; ++c) fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), stride, stride * w, 1, 1, 0.0));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (grey)
            for (std::size_t i = 0; i < w * h; ++i) image.data[i * 3 + 1] = image.data[i * 3 + 2] = image.data[i * 3];
        return image;
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error("cannot read " + path + ": bad metadata: " + e.what());
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path + ": " + e.what());
    }
}

namespace {

void rgbe_to_float(const unsigned char* rgbe, float* rgb, float exposure) {
    if (rgbe[3] == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0;
        return;
    }
    // Value = (mantissa + 0.5) * 2^(e - 136): the centre of the byte's interval (Ward's convention).
    const float f = std::ldexp(1.0f, int(rgbe[3]) - (128 + 8)) / exposure;
    for (int c = 0; c < 3; ++c) rgb[c] = (float(rgbe[c]) + 0.5f) * f;
}

}  // namespace

Image read_rgbe(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot open " + path);
    auto fail = [&](const std::string& why) { return std::runtime_error("cannot read Radiance HDR " + path + ": " + why); };
    std::string line;
    if (!std::getline(in, line) || (line.rfind("#?RADIANCE", 0) != 0 && line.rfind("#?RGBE", 0) != 0))
        throw fail("no #?RADIANCE or #?RGBE signature");
    float exposure = 1;
    bool format_ok = true;
    for (;;) {
        if (!std::getline(in, line)) throw fail("header has no blank line");
        if (line.empty()) break;
        if (line.rfind("FORMAT=", 0) == 0) format_ok = line.substr(7) == "32-bit_rle_rgbe";
        if (line.rfind("EXPOSURE=", 0) == 0) {
            const float e = std::strtof(line.c_str() + 9, nullptr);
            if (e > 0 && std::isfinite(e)) exposure *= e;
        }
    }
    if (!format_ok) throw fail("FORMAT is not 32-bit_rle_rgbe (XYZE is not supported)");
    if (!std::getline(in, line)) throw fail("no resolution line");
    char ya[3] = {}, xa[3] = {};
    int h = 0, w = 0;
    if (std::sscanf(line.c_str(), "%2s %d %2s %d", ya, &h, xa, &w) != 4 || std::string(ya) != "-Y" || std::string(xa) != "+X")
        throw fail("resolution line '" + line + "' (only -Y H +X W is supported)");
    if (w <= 0 || h <= 0 || w > 65536 || h > 65536) throw fail("bad size");
    Image image(std::uint32_t(w), std::uint32_t(h), {"R", "G", "B"});
    std::vector<unsigned char> scan(std::size_t(w) * 4);
    auto get = [&]() {
        const int c = in.get();
        if (c == EOF) throw fail("truncated pixel data");
        return (unsigned char)c;
    };
    for (int y = 0; y < h; ++y) {
        unsigned char head[4];
        for (auto& b : head) b = get();
        const bool rle = w >= 8 && w < 32768 && head[0] == 2 && head[1] == 2 && !(head[2] & 0x80);
        if (rle) {
            if ((int(head[2]) << 8 | head[3]) != w) throw fail("scanline width mismatch");
            for (int c = 0; c < 4; ++c) {
                int x = 0;
                while (x < w) {
                    int count = get();
                    if (count > 128) {
                        count -= 128;
                        if (x + count > w) throw fail("bad run");
                        const unsigned char v = get();
                        for (int k = 0; k < count; ++k) scan[std::size_t(x++) * 4 + c] = v;
                    } else {
                        if (count == 0 || x + count > w) throw fail("bad literal run");
                        for (int k = 0; k < count; ++k) scan[std::size_t(x++) * 4 + c] = get();
                    }
                }
            }
        } else {
            // Flat scanline (old-style runs are not supported: rare in practice).
            std::memcpy(&scan[0], head, 4);
            for (std::size_t i = 4; i < scan.size(); ++i) scan[i] = get();
        }
        for (int x = 0; x < w; ++x) rgbe_to_float(&scan[std::size_t(x) * 4], &image.at(std::uint32_t(x), std::uint32_t(y), 0), exposure);
    }
    return image;
}

Image read_environment_image(const std::string& path) {
    std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".exr") return read_exr_rgb(path);
    if (ext == ".hdr" || ext == ".pic") return read_rgbe(path);
    throw std::invalid_argument("environment " + path + ": expected an .exr or a Radiance .hdr file");
}

}  // namespace ms::env
