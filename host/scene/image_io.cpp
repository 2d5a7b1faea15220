#include "scene/image_io.hpp"

#include "io/exr_preflight.hpp"
#include "io/png_file.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputPart.h>
#include <ImfMultiPartInputFile.h>
#include <ImfPartType.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <png.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>

namespace ms::scene {

namespace {

bool is_png(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw SceneError(path + ": cannot open for reading");
    unsigned char sig[8] = {};
    f.read(reinterpret_cast<char*>(sig), 8);
    return f.gcount() == 8 && png_sig_cmp(sig, 0, 8) == 0;
}

std::string join(const std::vector<std::string>& names, std::size_t max = 24) {
    std::string s;
    for (std::size_t i = 0; i < names.size() && i < max; ++i) s += (i ? ", " : "") + names[i];
    if (names.size() > max) s += ", ... (" + std::to_string(names.size()) + " in all)";
    return s;
}

// --- PNG ------------------------------------------------------------------------------------------

struct PngPixels {
    std::uint32_t width = 0, height = 0, channels = 0;
    int bit_depth = 8;
    std::vector<std::string> names;
    std::vector<float> data;  // interleaved, scaled to [0, 1]
};

PngPixels read_png(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw SceneError(path + ": cannot open for reading");
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        throw std::runtime_error("libpng: out of memory");
    }
    // Rows live in a buffer allocated before setjmp, so a longjmp leaks nothing with a destructor.
    PngPixels out;
    std::vector<png_byte> buffer;
    std::vector<png_bytep> rows;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        throw SceneError(path + ": not a readable PNG (libpng failed)");
    }
    png_init_io(png, f);
    png_set_user_limits(png, 65536, 65536);
    png_read_info(png, info);
    const png_byte color = png_get_color_type(png, info);
    if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (color == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(png, info) < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    png_read_update_info(png, info);
    out.width = png_get_image_width(png, info);
    out.height = png_get_image_height(png, info);
    out.channels = png_get_channels(png, info);
    out.bit_depth = png_get_bit_depth(png, info);
    const std::size_t rowbytes = png_get_rowbytes(png, info);
    buffer.resize(rowbytes * out.height);
    rows.resize(out.height);
    for (std::uint32_t y = 0; y < out.height; ++y) rows[y] = buffer.data() + y * rowbytes;
    png_read_image(png, rows.data());
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    switch (out.channels) {
        case 1: out.names = {"Y"}; break;
        case 2: out.names = {"Y", "A"}; break;
        case 3: out.names = {"R", "G", "B"}; break;
        default: out.names = {"R", "G", "B", "A"}; break;
    }
    const std::size_t n = std::size_t(out.width) * out.height * out.channels;
    out.data.resize(n);
    if (out.bit_depth == 16) {
        for (std::size_t i = 0; i < n; ++i)
            out.data[i] = float(double((buffer[2 * i] << 8) | buffer[2 * i + 1]) / 65535.0);  // big-endian
    } else {
        for (std::size_t i = 0; i < n; ++i) out.data[i] = float(double(buffer[i]) / 255.0);
    }
    return out;
}

int png_channel_index(const PngPixels& p, const std::string& name) {
    for (std::size_t i = 0; i < p.names.size(); ++i)
        if (p.names[i] == name) return int(i);
    if (p.names[0] == "Y" && name == "R") return 0;  // grey read as its red channel
    return -1;
}

// --- OpenEXR --------------------------------------------------------------------------------------

struct ExrChannel {
    int part = 0;
    std::string part_name, channel;
};

std::vector<ExrChannel> exr_channels(Imf::MultiPartInputFile& file) {
    std::vector<ExrChannel> out;
    for (int p = 0; p < file.parts(); ++p) {
        const Imf::Header& h = file.header(p);
        if (h.hasType() && (h.type() == Imf::DEEPSCANLINE || h.type() == Imf::DEEPTILE)) continue;
        const std::string part_name = h.hasName() ? h.name() : "";
        for (auto it = h.channels().begin(); it != h.channels().end(); ++it) out.push_back({p, part_name, it.name()});
    }
    return out;
}

std::vector<std::string> exr_names(const std::vector<ExrChannel>& channels, bool multipart) {
    std::vector<std::string> names;
    for (const auto& c : channels) names.push_back(multipart && !c.part_name.empty() ? c.part_name + "." + c.channel : c.channel);
    return names;
}

}  // namespace

std::vector<std::string> list_channels(const std::string& path) {
    if (is_png(path)) return read_png(path).names;
    try {
        exr::preflight_image(path);  // claims the file cannot hold are refused before OpenEXR allocates them
        Imf::MultiPartInputFile file(path.c_str());
        return exr_names(exr_channels(file), file.parts() > 1);
    } catch (const std::exception& e) {
        throw SceneError(path + ": not a readable PNG or OpenEXR file (" + e.what() + ")");
    }
}

std::vector<Plane> read_channels(const std::string& path, const std::vector<std::string>& channels) {
    std::vector<Plane> planes;
    if (is_png(path)) {
        const PngPixels p = read_png(path);
        for (const auto& name : channels) {
            const int c = png_channel_index(p, name);
            if (c < 0)
                throw SceneError(path + ": channel '" + name + "' not found (this " + std::to_string(p.bit_depth) +
                                 "-bit PNG has " + join(p.names) + ")");
            Plane plane{path, name, p.width, p.height, {}, p.bit_depth == 16 ? 65535.0 : 255.0};
            plane.data.resize(std::size_t(p.width) * p.height);
            for (std::size_t i = 0; i < plane.data.size(); ++i) plane.data[i] = p.data[i * p.channels + std::size_t(c)];
            planes.push_back(std::move(plane));
        }
        return planes;
    }
    try {
        exr::preflight_image(path);  // claims the file cannot hold are refused before OpenEXR allocates them
        Imf::MultiPartInputFile file(path.c_str());
        const std::vector<ExrChannel> all = exr_channels(file);
        const bool multipart = file.parts() > 1;
        for (const auto& name : channels) {
            std::vector<const ExrChannel*> found;
            for (const auto& c : all)
                if (c.channel == name || (!c.part_name.empty() && c.part_name + "." + c.channel == name)) found.push_back(&c);
            if (found.empty())
                throw SceneError(path + ": channel '" + name + "' not found (the file has " + join(exr_names(all, multipart)) + ")");
            if (found.size() > 1) {
                std::vector<std::string> where;
                for (const auto* c : found) where.push_back("part " + std::to_string(c->part) + " '" + c->part_name + "'");
                throw SceneError(path + ": channel '" + name + "' is in several parts (" + join(where) +
                                 "); name it as '<part name>." + name + "'");
            }
            const ExrChannel& c = *found.front();
            const Imf::Header& h = file.header(c.part);
            const Imf::Channel& ch = h.channels()[c.channel.c_str()];
            if (ch.xSampling != 1 || ch.ySampling != 1)
                throw SceneError(path + ": channel '" + name + "' is subsampled; only full-resolution channels are read");
            const Imath::Box2i dw = h.dataWindow();
            const long w = long(dw.max.x) - dw.min.x + 1, hh = long(dw.max.y) - dw.min.y + 1;
            if (w <= 0 || hh <= 0 || w > 65536 || hh > 65536)
                throw SceneError(path + ": data window of " + std::to_string(w) + " x " + std::to_string(hh) + " pixels");
            Plane plane{path, name, std::uint32_t(w), std::uint32_t(hh), {}, 1.0};
            plane.data.assign(std::size_t(w) * std::size_t(hh), 0.0f);
            Imf::FrameBuffer fb;
            char* base = reinterpret_cast<char*>(plane.data.data()) -
                         (std::ptrdiff_t(dw.min.x) + std::ptrdiff_t(dw.min.y) * w) * std::ptrdiff_t(sizeof(float));
            fb.insert(c.channel.c_str(), Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * std::size_t(w)));
            Imf::InputPart part(file, c.part);
            part.setFrameBuffer(fb);
            part.readPixels(dw.min.y, dw.max.y);
            planes.push_back(std::move(plane));
        }
    } catch (const SceneError&) {
        throw;
    } catch (const std::exception& e) {
        throw SceneError(path + ": not a readable PNG or OpenEXR file (" + e.what() + ")");
    }
    return planes;
}

void write_png_rgb(const std::string& path, const RgbImage& image) {
    write_png(path, PngImage{image.width, image.height, 3, 8, image.pixels.data()});
}

void write_exr(const std::string& path, std::uint32_t width, std::uint32_t height, const std::vector<ExrLayer>& layers,
               const std::vector<std::pair<std::string, std::string>>& attributes) {
    Imf::Header header{int(width), int(height)};
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& l : layers) header.channels().insert(l.name.c_str(), Imf::Channel(Imf::FLOAT));
    for (const auto& [k, v] : attributes) header.insert(k.c_str(), Imf::StringAttribute(v));
    Imf::OutputFile out(path.c_str(), header);
    Imf::FrameBuffer fb;
    for (const auto& l : layers)
        fb.insert(l.name.c_str(), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(l.data)), sizeof(float),
                                             sizeof(float) * std::size_t(width)));
    out.setFrameBuffer(fb);
    out.writePixels(int(height));
}

}  // namespace ms::scene
