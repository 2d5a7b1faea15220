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
#include <iomanip>
#include <sstream>
#include <stdexcept>


#include <cerrno>

#include "env/cubemap_file.hpp"
#include "io/atomic_file.hpp"
#include "io/bounded_json.hpp"
#include "io/exr_file.hpp"
#include "io/exr_preflight.hpp"
#include "io/input_guard.hpp"
#include "platform/files.hpp"

namespace ms::env {

namespace {
Imf::Header checked_header(const Image& image, const nlohmann::json& metadata, bool half) {
    if (image.width == 0 || image.height == 0 || image.channels == 0 ||
        image.data.size() != std::size_t(image.width) * image.height * image.channels ||
        image.channel_names.size() != image.channels)
        throw std::invalid_argument("write_exr: inconsistent image");
    Imf::Header header = exr::image_header(image.width, image.height, image.channel_names, half);
    exr::insert_metadata(header, metadata);
    return header;
}
}  // namespace

void write_exr(const std::string& path, const Image& image, const nlohmann::json& metadata, bool half) {
    exr::write_interleaved(path, checked_header(image, metadata, half), image.channel_names, image.data, image.channels, half);
}

void write_exr_file(const std::string& file, const std::string& named, const Image& image, const nlohmann::json& metadata, bool half) {
    exr::write_interleaved_file(file, named, checked_header(image, metadata, half), image.channel_names, image.data, image.channels, half);
}

namespace {

// Opens `path` for reading without blocking (a FIFO without a writer would block open() itself, and the
// interrupt handlers cannot stop a blocked open), then refuses anything but a regular file. Returns the
// descriptor (the caller closes it) and the file's size.
int open_regular_file(const std::string& path, std::uint64_t& size) {
    using platform::FileKind;
    const int fd = platform::open_file(path, platform::read_only | platform::non_blocking);
    if (fd < 0) throw EnvironmentError("environment " + path + ": cannot open for reading (" + std::strerror(errno) + ")");
    platform::FileStatus st;
    if (platform::descriptor_status(fd, st) != 0) {
        const int err = errno;
        platform::close_file(fd);
        throw EnvironmentError("environment " + path + ": cannot read (" + std::strerror(err) + ")");
    }
    if (st.kind != FileKind::regular) {
        platform::close_file(fd);
        const std::string kind = st.kind == FileKind::directory || st.kind == FileKind::fifo || st.kind == FileKind::socket
                                     ? platform::kind_phrase(st.kind)
                                     : "a device";
        throw EnvironmentError("environment " + path + ": is " + kind + ", not a regular file");
    }
    size = st.size;
    note_input(path);
    return fd;
}

void check_regular_file(const std::string& path) {
    std::uint64_t size = 0;
    platform::close_file(open_regular_file(path, size));
}

std::string read_regular_file(const std::string& path) {
    std::uint64_t size = 0;
    const int fd = open_regular_file(path, size);
    std::string bytes;
    try {
        bytes.resize(std::size_t(size));
    } catch (const std::bad_alloc&) {
        platform::close_file(fd);
        throw EnvironmentError("environment " + path + ": " + std::to_string(size) + " bytes do not fit in memory");
    }
    std::size_t done = 0;
    while (done < bytes.size()) {
        const long long n = platform::read_some(fd, &bytes[done], bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int err = n < 0 ? errno : 0;
            platform::close_file(fd);
            throw EnvironmentError("environment " + path + ": read error" +
                                   (err ? std::string(" (") + std::strerror(err) + ")" : std::string(" (the file shrank)")));
        }
        done += std::size_t(n);
    }
    platform::close_file(fd);
    return bytes;
}

std::string describe_value(double v) {
    if (std::isnan(v)) return "NaN";
    if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
    std::ostringstream s;
    s << std::setprecision(7) << v;
    return s.str();
}

// The first value that is not a number, above kMaxRadiance, or negative beyond the residue, named with
// its texel and channel; residue negatives become 0 (counted in image.negative_residue_values).
void check_radiance(Image& image, const std::string& name) {
    auto refuse = [&](std::uint32_t x, std::uint32_t y, std::uint32_t c, float v) {
        std::ostringstream s;
        s << "environment " << name << ": texel (" << x << ", " << y << ") channel " << image.channel_names[c] << " is "
          << describe_value(v) << "; radiance must be finite, at most " << kMaxRadiance << " and non-negative (down to -"
          << kNegativeResidue << " x the image's largest value is read as 0) (fix or clamp the image)";
        throw EnvironmentError(s.str());
    };
    float largest = 0;
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x)
            for (std::uint32_t c = 0; c < image.channels; ++c) {
                const float v = image.at(x, y, c);
                if (!(v <= kMaxRadiance) || !std::isfinite(v)) refuse(x, y, c, v);
                largest = std::max(largest, v);
            }
    const float residue = kNegativeResidue * largest;
    for (std::uint32_t y = 0; y < image.height; ++y)
        for (std::uint32_t x = 0; x < image.width; ++x)
            for (std::uint32_t c = 0; c < image.channels; ++c) {
                float& v = image.at(x, y, c);
                if (v >= 0) continue;
                if (-v > residue) refuse(x, y, c, v);
                v = 0;
                ++image.negative_residue_values;
            }
}

std::string join_names(const std::vector<std::string>& names) {
    if (names.empty()) return "no channels";
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
    return s;
}

}  // namespace

void check_environment_file(const std::string& path) { check_regular_file(path); }

Image read_exr_rgb(const std::string& path, nlohmann::json* metadata) {
    check_regular_file(path);
    Image image;
    try {
        exr::preflight_image(path);  // claims the file cannot hold are refused before OpenEXR allocates them
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        if (metadata) {
            const auto* attr = header.findTypedAttribute<Imf::StringAttribute>("microshadow");
            *metadata = attr ? parse_bounded_json(attr->value(), "the \"microshadow\" attribute") : nlohmann::json::object();
        }
        const Imath::Box2i dw = header.dataWindow();
        const std::size_t w = std::size_t(dw.max.x - dw.min.x + 1), h = std::size_t(dw.max.y - dw.min.y + 1);
        if (w == 0 || h == 0 || w > 65536 || h > 65536) throw EnvironmentError("environment " + path + ": bad data window");
        // Exactly R, G and B (or Y alone): a missing channel read as 0 would give a plausible, wrong result.
        std::vector<std::string> present;
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it) present.push_back(it.name());
        const auto has = [&](const char* n) { return header.channels().findChannel(n) != nullptr; };
        const bool rgb = has("R") && has("G") && has("B");
        // "Y alone": Y beside X and Z is CIE XYZ, beside RY and BY luminance/chroma; its grey would be wrong.
        const bool other_colour = has("X") || has("Z") || has("RY") || has("BY");
        if (!rgb && has("Y") && other_colour)
            throw EnvironmentError("environment " + path + ": channels " + join_names(present) +
                                   " are not RGB (CIE XYZ or luminance/chroma); an environment is read from channels named "
                                   "exactly R, G and B, or Y alone: convert the image to RGB");
        const bool grey = !has("R") && !has("G") && !has("B") && has("Y") && !other_colour;
        if (!rgb && !grey) {
            std::string missing;
            for (const char* n : {"R", "G", "B"})
                if (!has(n)) missing += std::string(missing.empty() ? "" : ", ") + n;
            const bool some = has("R") || has("G") || has("B");
            throw EnvironmentError("environment " + path + ": " +
                                   (some ? "channel" + std::string(missing.size() > 1 ? "s " : " ") + missing + " missing"
                                         : std::string("no R, G, B or Y channel")) +
                                   " (the file has " + join_names(present) +
                                   "); an environment is read from channels named exactly R, G and B, or Y alone");
        }
        const std::vector<const char*> used = grey ? std::vector<const char*>{"Y"} : std::vector<const char*>{"R", "G", "B"};
        for (const char* n : used) {
            const Imf::Channel* ch = header.channels().findChannel(n);
            if (ch->xSampling != 1 || ch->ySampling != 1)
                throw EnvironmentError("environment " + path + ": channel " + n + " is subsampled (" + std::to_string(ch->xSampling) +
                                       " x " + std::to_string(ch->ySampling) + "); only full-resolution channels are read");
        }
        image = Image(std::uint32_t(w), std::uint32_t(h), {"R", "G", "B"});
        Imf::FrameBuffer fb;
        const std::size_t stride = 3 * sizeof(float);
        char* base = exr::frame_base(image.data.data(), dw.min.x, dw.min.y, stride, stride * w);
        for (std::size_t c = 0; c < used.size(); ++c)
            fb.insert(used[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), stride, stride * w, 1, 1, 0.0));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (grey) {
            image.channel_names = {"Y", "Y", "Y"};  // for messages: the texel check names the file's channel
            for (std::size_t i = 0; i < w * h; ++i) image.data[i * 3 + 1] = image.data[i * 3 + 2] = image.data[i * 3];
        }
    } catch (const EnvironmentError&) {
        throw;
    } catch (const nlohmann::json::exception& e) {
        throw EnvironmentError("environment " + path + ": bad metadata: " + e.what());
    } catch (const std::exception& e) {
        // OpenEXR's own refusals (truncated, corrupt or unsupported data) and the preflight's: bad input.
        throw EnvironmentError("cannot read " + path + ": " + e.what());
    }
    check_radiance(image, path);
    image.channel_names = {"R", "G", "B"};
    return image;
}

namespace {

// The smallest number of bytes a Radiance scanline of `width` pixels can take: flat (4 bytes a pixel),
// or, for widths 8 to 32767, run-length encoded: a 4-byte header, then per channel runs of at most 127
// equal bytes at 2 bytes each (a literal run of 128 takes 129).
std::uint64_t smallest_rgbe_scanline(std::uint64_t width) {
    const std::uint64_t flat = 4 * width;
    if (width < 8 || width >= 32768) return flat;
    return std::min(flat, 4 + 4 * 2 * ((width + 126) / 127));
}

}  // namespace

Image decode_rgbe(const std::string& bytes, const std::string& path) {
    auto fail = [&](const std::string& why) { return EnvironmentError("cannot read Radiance HDR " + path + ": " + why); };
    std::size_t pos = 0;
    // One header line (without its '\n'); false at the end of the bytes.
    auto next_line = [&](std::string& line) {
        if (pos >= bytes.size()) return false;
        const std::size_t end = bytes.find('\n', pos);
        if (end == std::string::npos) {
            line = bytes.substr(pos);
            pos = bytes.size();
        } else {
            line = bytes.substr(pos, end - pos);
            pos = end + 1;
        }
        return true;
    };
    std::string line;
    if (!next_line(line) || (line.rfind("#?RADIANCE", 0) != 0 && line.rfind("#?RGBE", 0) != 0))
        throw fail("no #?RADIANCE or #?RGBE signature");
    double exposure = 1;
    bool format_ok = true;
    for (;;) {
        if (!next_line(line)) throw fail("header has no blank line");
        if (line.empty()) break;
        if (line.rfind("FORMAT=", 0) == 0) format_ok = line.substr(7) == "32-bit_rle_rgbe";
        if (line.rfind("EXPOSURE=", 0) == 0) {
            // Pixel values were multiplied by EXPOSURE when written: each must be a usable factor.
            const std::string value = line.substr(9);
            char* end = nullptr;
            const double e = std::strtod(value.c_str(), &end);
            while (*end == ' ' || *end == '\t' || *end == '\r') ++end;
            if (end == value.c_str() || *end || !std::isfinite(e) || !(e > 0))
                throw fail("header line '" + line + "': EXPOSURE must be a finite positive number");
            exposure *= e;
            if (!(exposure > 0) || !std::isfinite(exposure))
                throw fail("header line '" + line + "': the product of the EXPOSURE lines is " + describe_value(exposure));
        }
    }
    if (!format_ok) throw fail("FORMAT is not 32-bit_rle_rgbe (XYZE is not supported)");
    if (!next_line(line)) throw fail("no resolution line");
    char ya[3] = {}, xa[3] = {};
    long long h = 0, w = 0;
    if (std::sscanf(line.c_str(), "%2s %lld %2s %lld", ya, &h, xa, &w) != 4 || std::string(ya) != "-Y" || std::string(xa) != "+X")
        throw fail("resolution line '" + line + "' (only -Y H +X W is supported)");
    if (w <= 0 || h <= 0 || w > 65536 || h > 65536)
        throw fail("resolution line '" + line + "': width and height must be 1 to 65536");
    // The header's claim bounded before anything is allocated: a pixel limit, and the bytes left.
    const std::uint64_t pixels = std::uint64_t(w) * std::uint64_t(h);
    if (pixels > exr::kMaxImagePixels)
        throw fail(std::to_string(w) + " x " + std::to_string(h) + " is " + std::to_string(pixels) + " pixels, more than the limit of " +
                   std::to_string(exr::kMaxImagePixels) + " (16384 x 16384)");
    const std::uint64_t needed = std::uint64_t(h) * smallest_rgbe_scanline(std::uint64_t(w));
    const std::uint64_t left = bytes.size() - pos;
    if (left < needed)
        throw fail("truncated pixel data: " + std::to_string(w) + " x " + std::to_string(h) + " needs at least " + std::to_string(needed) +
                   " bytes, the file has " + std::to_string(left) + " after its header");
    Image image(std::uint32_t(w), std::uint32_t(h), {"R", "G", "B"});
    std::vector<unsigned char> scan(std::size_t(w) * 4);
    auto get = [&]() {
        if (pos >= bytes.size()) throw fail("truncated pixel data");
        return (unsigned char)bytes[pos++];
    };
    for (long long y = 0; y < h; ++y) {
        unsigned char head[4];
        for (auto& b : head) b = get();
        const bool rle = w >= 8 && w < 32768 && head[0] == 2 && head[1] == 2 && !(head[2] & 0x80);
        if (rle) {
            if ((int(head[2]) << 8 | head[3]) != w) throw fail("scanline " + std::to_string(y) + ": width mismatch");
            for (int c = 0; c < 4; ++c) {
                long long x = 0;
                while (x < w) {
                    int count = get();
                    if (count > 128) {
                        count -= 128;
                        if (x + count > w) throw fail("scanline " + std::to_string(y) + ": bad run");
                        const unsigned char v = get();
                        for (int k = 0; k < count; ++k) scan[std::size_t(x++) * 4 + std::size_t(c)] = v;
                    } else {
                        if (count == 0 || x + count > w) throw fail("scanline " + std::to_string(y) + ": bad literal run");
                        for (int k = 0; k < count; ++k) scan[std::size_t(x++) * 4 + std::size_t(c)] = get();
                    }
                }
            }
        } else {
            // Flat scanline (old-style runs are not supported: rare in practice).
            std::memcpy(&scan[0], head, 4);
            for (std::size_t i = 4; i < scan.size(); ++i) scan[i] = get();
        }
        for (long long x = 0; x < w; ++x) {
            const unsigned char* rgbe = &scan[std::size_t(x) * 4];
            float* rgb = &image.at(std::uint32_t(x), std::uint32_t(y), 0);
            if (rgbe[3] == 0) {
                rgb[0] = rgb[1] = rgb[2] = 0;
                continue;
            }
            // Value = (mantissa + 0.5) * 2^(e - 136) / exposure: the centre of the byte's interval (Ward's
            // convention), in double so an exposure that overflows float is caught before the cast.
            const double f = std::ldexp(1.0, int(rgbe[3]) - (128 + 8)) / exposure;
            for (int c = 0; c < 3; ++c) {
                const double v = (double(rgbe[c]) + 0.5) * f;
                if (!(v <= kMaxRadiance)) {
                    std::ostringstream s;
                    s << "texel (" << x << ", " << y << ") channel " << "RGB"[c] << " is " << describe_value(v) << " (exposure "
                      << exposure << "); radiance must be at most " << kMaxRadiance;
                    throw fail(s.str());
                }
                rgb[c] = float(v);
            }
        }
    }
    return image;
}

Image read_rgbe(const std::string& path) { return decode_rgbe(read_regular_file(path), path); }

Image read_environment_image(const std::string& path) {
    std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size() : path.find_last_of('.'));
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".exr") return read_exr_rgb(path);
    if (ext == ".hdr" || ext == ".pic") return read_rgbe(path);
    // A cubemap file's base level, unfolded into the horizontal cross cubemap_from_image takes back as it is.
    if (ext == ".ktx2" || ext == ".dds") return cross_image(read_cubemap_file(path).levels.at(0));
    throw EnvironmentError("environment " + path + ": expected an .exr or a Radiance .hdr file, or a .ktx2 / .dds cubemap");
}

}  // namespace ms::env
