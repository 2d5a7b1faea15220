#include "lut/exr_lut.hpp"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <Imath/half.h>

#include <cmath>
#include <stdexcept>

#include "io/atomic_file.hpp"

namespace ms {

namespace {
const char* const kChannelNames[4] = {"R", "G", "B", "A"};
const char* const kAxisNames[3] = {"visibility", "n_dot_l", "n_dot_v"};

nlohmann::json axis_json(const LutAxis& a) {
    return {{"name", a.name}, {"min", a.min}, {"max", a.max}, {"count", a.count}, {"texel", to_string(a.texel)}};
}
}  // namespace


void write_lut(const std::string& path, const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels,
               const std::vector<float>& data, const nlohmann::json& metadata, bool half) {
    if (axes.size() != 3) throw std::invalid_argument("write_lut: need the visibility, n_dot_l and n_dot_v axes");
    if (channels.empty() || channels.size() > 4) throw std::invalid_argument("write_lut: 1 to 4 channels");
    for (std::size_t c = 0; c < channels.size(); ++c)
        if (channels[c].name != kChannelNames[c]) throw std::invalid_argument("write_lut: channels must be R, G, B, A in order");
    const std::size_t width = axes[0].count, height = std::size_t(axes[1].count) * axes[2].count;
    if (width == 0 || height == 0 || data.size() != width * height * channels.size())
        throw std::invalid_argument("write_lut: data size does not match the axes");

    nlohmann::json meta = metadata;
    meta["axes"] = nlohmann::json::array();
    for (const auto& a : axes) meta["axes"].push_back(axis_json(a));
    meta["channels"] = nlohmann::json::array();
    for (const auto& c : channels)
        meta["channels"].push_back({{"name", c.name}, {"roughness", c.roughness}, {"alpha_x", c.alpha_x}, {"alpha_y", c.alpha_y}});

    check_writable_destination(path);
    AtomicPath atomic(path);
    {
        Imf::Header header{int(width), int(height)};
        header.compression() = Imf::ZIP_COMPRESSION;
        for (std::size_t c = 0; c < channels.size(); ++c)
            header.channels().insert(kChannelNames[c], Imf::Channel(half ? Imf::HALF : Imf::FLOAT));
        header.insert("microshadow", Imf::StringAttribute(meta.dump()));
        // Typed copies of the main fields, for people reading the header with exrheader.
        for (auto it = meta.begin(); it != meta.end(); ++it) {
            const std::string name = "microshadow." + it.key();
            if (it->is_string()) header.insert(name, Imf::StringAttribute(it->get<std::string>()));
            else if (it->is_number_integer() && std::abs(it->get<double>()) < 2147483647.0)
                header.insert(name, Imf::IntAttribute(it->get<int>()));
            else if (it->is_number()) header.insert(name, Imf::DoubleAttribute(it->get<double>()));
            else if (it->is_boolean()) header.insert(name, Imf::IntAttribute(it->get<bool>() ? 1 : 0));
        }
        for (std::size_t i = 0; i < 3; ++i) {
            const std::string p = std::string("microshadow.axis.") + kAxisNames[i] + ".";
            header.insert(p + "min", Imf::DoubleAttribute(axes[i].min));
            header.insert(p + "max", Imf::DoubleAttribute(axes[i].max));
            header.insert(p + "count", Imf::IntAttribute(int(axes[i].count)));
            header.insert(p + "texel", Imf::StringAttribute(to_string(axes[i].texel)));
        }
        for (const auto& c : channels) header.insert("microshadow.roughness." + c.name, Imf::DoubleAttribute(c.roughness));

        // OpenEXR does not convert FLOAT to HALF on write: round to half here (round to nearest even).
        std::vector<Imath::half> halves;
        if (half) halves.assign(data.begin(), data.end());
        Imf::FrameBuffer fb;
        const std::size_t elem = half ? sizeof(Imath::half) : sizeof(float);
        const std::size_t stride = channels.size() * elem;
        char* base = half ? (char*)halves.data() : (char*)data.data();
        for (std::size_t c = 0; c < channels.size(); ++c)
            fb.insert(kChannelNames[c], Imf::Slice(half ? Imf::HALF : Imf::FLOAT, base + c * elem, stride, stride * width));
        try {
            Imf::OutputFile file(atomic.temp_path().c_str(), header);
            file.setFrameBuffer(fb);
            file.writePixels(int(height));
        } catch (const std::exception& e) {
            throw std::runtime_error("cannot write " + path + ": " + e.what());
        }
    }
    atomic.commit();
}

LutFile read_lut(const std::string& path) {
    LutFile lut;
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        const auto* attr = header.findTypedAttribute<Imf::StringAttribute>("microshadow");
        if (!attr) throw std::runtime_error("no \"microshadow\" header attribute: not a microshadow LUT");
        lut.metadata = nlohmann::json::parse(attr->value());
        const auto& axes = lut.metadata.at("axes");
        if (!axes.is_array() || axes.size() != 3) throw std::runtime_error("metadata must list 3 axes");
        for (std::size_t i = 0; i < 3; ++i) {
            LutAxis a;
            a.name = axes[i].at("name").get<std::string>();
            if (a.name != kAxisNames[i]) throw std::runtime_error("axis " + std::to_string(i) + " must be " + kAxisNames[i]);
            a.min = axes[i].at("min").get<double>();
            a.max = axes[i].at("max").get<double>();
            a.count = axes[i].at("count").get<std::uint32_t>();
            a.texel = parse_texel_convention(axes[i].at("texel").get<std::string>());
            lut.axes.push_back(a);
        }
        for (const auto& c : lut.metadata.at("channels")) {
            LutChannel ch;
            ch.name = c.at("name").get<std::string>();
            ch.roughness = c.at("roughness").get<double>();
            ch.alpha_x = c.at("alpha_x").get<double>();
            ch.alpha_y = c.at("alpha_y").get<double>();
            lut.channels.push_back(ch);
        }
        if (lut.channels.empty() || lut.channels.size() > 4) throw std::runtime_error("metadata must list 1 to 4 channels");
        const Imath::Box2i dw = header.dataWindow();
        lut.width = std::uint32_t(dw.max.x - dw.min.x + 1);
        lut.height = std::uint32_t(dw.max.y - dw.min.y + 1);
        if (lut.width != lut.axes[0].count || lut.height != lut.axes[1].count * lut.axes[2].count)
            throw std::runtime_error("image size " + std::to_string(lut.width) + "x" + std::to_string(lut.height) +
                                     " does not match the axes");
        const std::size_t nc = lut.channels.size();
        for (std::size_t c = 0; c < nc; ++c) {
            const Imf::Channel* ch = header.channels().findChannel(lut.channels[c].name);
            if (!ch || lut.channels[c].name != kChannelNames[c])
                throw std::runtime_error("missing channel " + std::string(kChannelNames[c]));
            if (c == 0) lut.half = ch->type == Imf::HALF;
        }
        lut.data.assign(std::size_t(lut.width) * lut.height * nc, 0.0f);
        Imf::FrameBuffer fb;
        const std::size_t stride = nc * sizeof(float);
        // Data window may not start at (0, 0): offset the base pointer as OpenEXR expects.
        char* base = (char*)lut.data.data() - (std::ptrdiff_t(dw.min.x) * stride + std::ptrdiff_t(dw.min.y) * stride * lut.width);
        for (std::size_t c = 0; c < nc; ++c)
            fb.insert(kChannelNames[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), stride, stride * lut.width));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error("cannot read LUT " + path + ": bad metadata: " + e.what());
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read LUT " + path + ": " + e.what());
    }
    return lut;
}

}  // namespace ms
