#include "approx/lut.hpp"

#include "lut/shader/alu_count.hpp"
#include "lut/shader/shader_gen.hpp"

namespace ms::approx {

double lut_value(const LutLookup& lut, const Inputs& in) {
    return lut(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness);
}

Cost lut_cost(const LutFile& f, const std::string& source_name) {
    Cost c;
    const std::uint64_t channels = f.channels.size() <= 2 ? f.channels.size() : 4;
    c.bytes = std::uint64_t(f.width) * f.height * channels * 2;
    c.fetches_per_light = 1;
    c.alu_per_light = lutshader::count_alu(lutshader::generate_shader(f, lutshader::ShaderLanguage::glsl, source_name));
    const bool three_d = f.n_dot_v().count > 1;
    c.storage = std::string(three_d ? "3D" : "2D") + " texture " + std::to_string(f.visibility().count) + "x" +
                std::to_string(f.n_dot_l().count) + (three_d ? "x" + std::to_string(f.n_dot_v().count) : "") + " " +
                (channels == 1 ? "R16F" : channels == 2 ? "RG16F" : "RGBA16F");
    return c;
}

namespace {

class LutApproximation final : public Approximation {
public:
    LutApproximation(std::shared_ptr<const LutLookup> lut, std::string path)
        : lut_(std::move(lut)), path_(std::move(path)) {}
    std::string kind() const override { return "lut"; }
    // The file, not the layout: the layout's words come with the cost, which generates the shader.
    std::string name() const override { return "LUT " + path_; }
    // Computed when asked (it generates the shader): eval and sweeps ask only for provenance.
    Cost cost() const override { return lut_cost(lut_->file(), path_); }
    double operator()(const Inputs& in) const override { return lut_value(*lut_, in); }
    std::optional<LookupDomain> domain() const override { return lut_->domain(); }
    nlohmann::json provenance() const override {
        const Cost c = cost();
        nlohmann::json j{{"kind", "lut"},
                         {"cost", {{"bytes", c.bytes}, {"fetches_per_light", c.fetches_per_light}, {"alu_per_light", c.alu_per_light}, {"storage", c.storage}}},
                         {"domain", lut_->domain().to_json()}};
        const auto& meta = lut_->file().metadata;
        for (const char* key : {"version", "command_line"})
            if (meta.is_object() && meta.contains(key)) j[key] = meta[key];
        return j;
    }

private:
    std::shared_ptr<const LutLookup> lut_;
    std::string path_;
};

}  // namespace

std::shared_ptr<const Approximation> lut_approximation(std::shared_ptr<const LutLookup> lut, const std::string& path) {
    return std::make_shared<const LutApproximation>(std::move(lut), path);
}

std::shared_ptr<const Approximation> open_lut(const std::string& path) {
    return lut_approximation(std::make_shared<const LutLookup>(LutLookup::open(path)), path);
}

}  // namespace ms::approx
