// exr_pixel_hash FILE...: one 16-hex-digit hash per OpenEXR file, of its pixels only.
//
// The golden set (tests/golden/make_golden.sh) hashes LUT files by what a reader gets from them, not
// by their bytes: the header records the command line, the device and the time, which change from run
// to run while the numbers must not. Every channel is read as FLOAT (half channels are widened exactly),
// and FNV-1a 64 runs over the data window's width and height (4-byte ints, host order), then per channel
// in the header's (alphabetical) order its name and its width x height float bits, row-major.
// Exit status 1 (with the reason on stderr) when a file cannot be read.
#include <ImathBox.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>

#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

namespace {

struct Fnv1a64 {
    std::uint64_t h = 1469598103934665603ULL;
    void mix(const void* p, std::size_t n) {
        const auto* c = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) {
            h ^= c[i];
            h *= 1099511628211ULL;
        }
    }
};

std::uint64_t pixel_hash(const char* path) {
    Imf::InputFile in(path);
    const Imath::Box2i dw = in.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    std::vector<std::string> names;
    for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) names.push_back(it.name());
    std::vector<std::vector<float>> channels(names.size());
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < names.size(); ++c) {
        channels[c].assign(std::size_t(w) * h, 0.0f);
        // The slice's base is the address of pixel (0, 0), so that (dw.min.x, dw.min.y) lands on element 0.
        char* base = reinterpret_cast<char*>(channels[c].data()) -
                     (std::ptrdiff_t(dw.min.x) + std::ptrdiff_t(dw.min.y) * w) * std::ptrdiff_t(sizeof(float));
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * std::size_t(w)));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    Fnv1a64 f;
    f.mix(&w, 4);
    f.mix(&h, 4);
    for (std::size_t c = 0; c < names.size(); ++c) {
        f.mix(names[c].data(), names[c].size());
        f.mix(channels[c].data(), channels[c].size() * sizeof(float));
    }
    return f.h;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: exr_pixel_hash FILE.exr...\n");
        return 2;
    }
    for (int a = 1; a < argc; ++a) {
        try {
            std::printf("%016llx\n", static_cast<unsigned long long>(pixel_hash(argv[a])));
        } catch (const std::exception& e) {
            std::fprintf(stderr, "exr_pixel_hash: %s: %s\n", argv[a], e.what());
            return 1;
        }
    }
    return 0;
}
