#include "scene/image_io.hpp"

#include "io/exr_file.hpp"
#include "io/exr_preflight.hpp"
#include "io/input_guard.hpp"
#include "io/png_file.hpp"
#include "platform/files.hpp"

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
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <filesystem>
#include <map>
#include <memory>
#include <set>


namespace ms::scene {

namespace {

bool is_png(const std::string& path) {
    require_regular_file(path);
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
    bool palette = false;            // a palette PNG: R, G, B (A) are the palette's colours, "index" the stored index
    std::vector<std::string> names;
    std::vector<double> scale;       // per channel: the largest stored code (Plane::integer_scale)
    std::vector<float> data;         // interleaved, colours scaled to [0, 1], the index as stored
};

// libpng's messages go into the exception (its default handler prints them raw on stderr).
struct PngMessages {
    char error[256] = {};
};
void png_error_to_buffer(png_structp png, png_const_charp message) {
    auto* m = static_cast<PngMessages*>(png_get_error_ptr(png));
    std::snprintf(m->error, sizeof m->error, "%s", message ? message : "unknown error");
    png_longjmp(png, 1);
}
void png_warning_ignored(png_structp, png_const_charp) {}

// What deflate can expand a byte into, at most (a run of 258-byte matches at 2 bits a match: 1032),
// with room for the headers of a tiny file: a header that claims more pixel rows than the file could
// hold is refused before a byte of them is allocated.
constexpr std::uint64_t kDeflateMaxRatio = 1032;
constexpr std::uint64_t kPngSlackBytes = 1 << 16;

PngPixels read_png(const std::string& path) {
    const std::uint64_t file_bytes = std::filesystem::file_size(path);
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw SceneError(path + ": cannot open for reading");
    PngMessages messages;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &messages, png_error_to_buffer, png_warning_ignored);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        throw std::runtime_error("libpng: out of memory");
    }
    // Everything with a destructor is constructed before setjmp; a longjmp leaks nothing. A refusal of
    // our own is recorded in `refusal` and thrown after libpng is torn down.
    PngPixels out;
    std::vector<png_byte> buffer;
    std::vector<png_bytep> rows;
    std::string refusal;
    std::vector<png_color> palette;   // copied: libpng's own copy goes with the read struct
    std::vector<png_byte> palette_alpha;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        if (!refusal.empty()) throw SceneError(refusal);
        throw SceneError(path + ": not a readable PNG (libpng: " + std::string(messages.error) + ")");
    }
    png_init_io(png, f);
    png_set_user_limits(png, 65536, 65536);
    png_read_info(png, info);
    const png_byte color = png_get_color_type(png, info);
    const int stored_depth = png_get_bit_depth(png, info);
    {
        // The header's claim against the file's size and the pixel limit, before any pixel is allocated.
        const std::uint64_t w = png_get_image_width(png, info), h = png_get_image_height(png, info);
        const std::uint64_t stored_channels = png_get_channels(png, info);
        const std::uint64_t row_bytes = (w * stored_channels * std::uint64_t(stored_depth) + 7) / 8 + 1;  // + filter byte
        if (w * h > exr::kMaxImagePixels)
            refusal = path + ": claims " + std::to_string(w) + " x " + std::to_string(h) + " pixels, more than the limit of " +
                      std::to_string(exr::kMaxImagePixels) + " (16384 x 16384)";
        else if (row_bytes * h > kDeflateMaxRatio * file_bytes + kPngSlackBytes)
            refusal = path + ": claims " + std::to_string(w) + " x " + std::to_string(h) + " pixels (" +
                      std::to_string(row_bytes * h) + " bytes of rows) but the file is " + std::to_string(file_bytes) +
                      " bytes, more than compression can expand: truncated or not a PNG";
        if (!refusal.empty()) png_longjmp(png, 1);
    }
    out.palette = color == PNG_COLOR_TYPE_PALETTE;
    if (out.palette) {
        // Indices are kept (an object-index mask is a palette's indices, not its colours); colours are
        // looked up below.
        png_colorp entries = nullptr;
        int entry_count = 0;
        png_get_PLTE(png, info, &entries, &entry_count);
        palette.assign(entries, entries + entry_count);
        png_bytep alpha = nullptr;
        int alpha_count = 0;
        if (png_get_valid(png, info, PNG_INFO_tRNS)) png_get_tRNS(png, info, &alpha, &alpha_count, nullptr);
        if (alpha) palette_alpha.assign(alpha, alpha + alpha_count);
        png_set_packing(png);
    } else {
        if (color == PNG_COLOR_TYPE_GRAY && stored_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
        if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    }
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
    const std::size_t pixels = std::size_t(out.width) * out.height;
    if (out.palette) {
        const bool alpha = !palette_alpha.empty();
        const int palette_size = int(palette.size()), palette_alpha_size = int(palette_alpha.size());
        out.names = alpha ? std::vector<std::string>{"R", "G", "B", "A", "index"} : std::vector<std::string>{"R", "G", "B", "index"};
        out.scale.assign(out.names.size(), 255.0);
        out.scale.back() = 1.0;
        out.channels = std::uint32_t(out.names.size());
        out.data.resize(pixels * out.channels);
        for (std::size_t i = 0; i < pixels; ++i) {
            const int index = buffer[i];
            if (index >= palette_size)
                throw SceneError(path + ": pixel (" + std::to_string(i % out.width) + ", " + std::to_string(i / out.width) +
                                 "): palette index " + std::to_string(index) + " beyond the palette's " + std::to_string(palette_size) +
                                 " entries");
            float* px = &out.data[i * out.channels];
            px[0] = float(palette[index].red / 255.0);
            px[1] = float(palette[index].green / 255.0);
            px[2] = float(palette[index].blue / 255.0);
            if (alpha) px[3] = float((index < palette_alpha_size ? palette_alpha[index] : 255) / 255.0);
            px[out.channels - 1] = float(index);
        }
        return out;
    }
    switch (out.channels) {
        case 1: out.names = {"Y"}; break;
        case 2: out.names = {"Y", "A"}; break;
        case 3: out.names = {"R", "G", "B"}; break;
        default: out.names = {"R", "G", "B", "A"}; break;
    }
    out.scale.assign(out.names.size(), out.bit_depth == 16 ? 65535.0 : 255.0);
    const std::size_t n = pixels * out.channels;
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
    if (name == "index") return 0;                   // no palette: the first channel's stored codes
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

void require_regular_file(const std::string& path) {
    // stat, not open: opening a FIFO blocks until a writer appears, beyond the reach of SIGINT/SIGTERM.
    platform::FileStatus st;
    if (platform::path_status(path, st) != 0) throw SceneError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
    if (st.kind == platform::FileKind::regular) return note_input(path);
    const char* kind = platform::kind_phrase(st.kind);
    throw SceneError(path + ": is " + std::string(kind) + ", not a regular file (images and LUTs are read from files)");
}

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
            Plane plane{path, name, p.width, p.height, {}, p.scale[std::size_t(c)]};
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
                // Advice that can be followed: the qualified names that pick exactly one channel (a part
                // may lack a name, or a qualified name may equal another part's channel name).
                std::vector<std::string> where, can_name, cannot_name;
                for (const auto* c : found) {
                    const std::string part = "part " + std::to_string(c->part) + (c->part_name.empty() ? "" : " '" + c->part_name + "'");
                    where.push_back(part);
                    const std::string q = c->part_name + "." + c->channel;
                    std::size_t matches = 0;
                    for (const auto& other : all)
                        if (other.channel == q || (!other.part_name.empty() && other.part_name + "." + other.channel == q)) ++matches;
                    if (!c->part_name.empty() && q != name && matches == 1) can_name.push_back("'" + q + "' (" + part + ")");
                    else cannot_name.push_back(part);
                }
                std::string advice;
                if (!can_name.empty()) advice = "name " + join(can_name);
                if (!cannot_name.empty())
                    advice += std::string(advice.empty() ? "" : "; ") + "no name picks the channel of " + join(cannot_name) +
                              " (its part has no name, or the qualified name is taken): rename the part or the channel";
                throw SceneError(path + ": channel '" + name + "' is in several parts (" + join(where) + "): " + advice);
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
            Plane plane{path, name, std::uint32_t(w), std::uint32_t(hh), {}, 1.0, dw.min.x, dw.min.y};
            plane.data.assign(std::size_t(w) * std::size_t(hh), 0.0f);
            Imf::FrameBuffer fb;
            char* base = exr::frame_base(plane.data.data(), dw.min.x, dw.min.y, sizeof(float), sizeof(float) * std::size_t(w));
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
