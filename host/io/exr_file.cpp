#include "io/exr_file.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfIntAttribute.h>
#include <ImfDoubleAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <Imath/half.h>

#include <cmath>
#include <stdexcept>

#include "io/atomic_file.hpp"

namespace ms::exr {

Imf::Header image_header(std::uint32_t width, std::uint32_t height, const std::vector<std::string>& names, bool half) {
    Imf::Header header{int(width), int(height)};
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& name : names) header.channels().insert(name, Imf::Channel(half ? Imf::HALF : Imf::FLOAT));
    return header;
}

void insert_metadata(Imf::Header& header, const nlohmann::json& metadata) {
    header.insert("microshadow", Imf::StringAttribute(metadata.dump()));
    for (auto it = metadata.begin(); it != metadata.end(); ++it) {
        const std::string name = "microshadow." + it.key();
        if (it->is_string()) header.insert(name, Imf::StringAttribute(it->get<std::string>()));
        else if (it->is_number_integer() && std::abs(it->get<double>()) < 2147483647.0)
            header.insert(name, Imf::IntAttribute(it->get<int>()));
        else if (it->is_number()) header.insert(name, Imf::DoubleAttribute(it->get<double>()));
        else if (it->is_boolean()) header.insert(name, Imf::IntAttribute(it->get<bool>() ? 1 : 0));
    }
}

void write_interleaved_file(const std::string& file, const std::string& named, const Imf::Header& header,
                            const std::vector<std::string>& names, const std::vector<float>& data, std::size_t floats_per_pixel,
                            bool half) {
    const Imath::Box2i dw = header.dataWindow();
    const std::size_t width = std::size_t(dw.max.x - dw.min.x + 1), height = std::size_t(dw.max.y - dw.min.y + 1);
    if (names.size() > floats_per_pixel || data.size() != width * height * floats_per_pixel)
        throw std::invalid_argument("write_interleaved: " + named + ": data do not match the header");
    std::vector<Imath::half> halves;
    if (half) halves.assign(data.begin(), data.end());
    const std::size_t elem = half ? sizeof(Imath::half) : sizeof(float), stride = floats_per_pixel * elem;
    char* base = half ? reinterpret_cast<char*>(halves.data()) : const_cast<char*>(reinterpret_cast<const char*>(data.data()));
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < names.size(); ++c)
        fb.insert(names[c], Imf::Slice(half ? Imf::HALF : Imf::FLOAT, base + c * elem, stride, stride * width));
    try {
        Imf::OutputFile out(file.c_str(), header);
        out.setFrameBuffer(fb);
        out.writePixels(int(height));
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot write " + named + ": " + e.what());
    }
}

void write_interleaved(const std::string& path, const Imf::Header& header, const std::vector<std::string>& names,
                       const std::vector<float>& data, std::size_t floats_per_pixel, bool half) {
    check_writable_destination(path);
    AtomicPath atomic(path);
    write_interleaved_file(atomic.temp_path(), path, header, names, data, floats_per_pixel, half);
    atomic.commit();
}

}  // namespace ms::exr
