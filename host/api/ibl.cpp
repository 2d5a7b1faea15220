// microshadow::bake_dfg: `microshadow ibl dfg` (cli/cmd_ibl.cpp) as a call.
#include "microshadow/ibl.hpp"

#include <stdexcept>

#include "api/facade.hpp"
#include "jobs/ibl_dfg.hpp"
#include "sampling/point_set.hpp"

namespace microshadow {

struct DfgLut::Data {
    ms::DfgBakeSpec spec;
    ms::DfgBakeResult result;
    nlohmann::json metadata;
};

DfgLut::DfgLut(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::DfgLut: no data");
}

DfgLut bake_dfg(const DfgOptions& o, const Progress& progress) {
    auto data = std::make_shared<DfgLut::Data>();
    ms::DfgBakeSpec& spec = data->spec;
    spec.n_dot_v.count = o.n_dot_v_count ? o.n_dot_v_count : o.size;
    spec.roughness.count = o.roughness_count ? o.roughness_count : o.size;
    spec.n_dot_v.texel = spec.roughness.texel = ms::parse_texel_convention(o.texel);
    // The oracle backend is the quadrature, as the CLI's --backend oracle spells it.
    std::string method = o.method;
    if (detail::backend_spec(o.backend, o.device).is_oracle()) {
        if (o.method != "sampled" && o.method != "quadrature")
            throw std::invalid_argument("microshadow::bake_dfg: backend oracle contradicts method " + o.method);
        method = "quadrature";
    }
    spec.method = ms::parse_dfg_method(method);
    spec.channels = ms::parse_dfg_channels(o.channels);
    spec.parameterization = ms::parse_dfg_parameterization(o.parameterization);
    spec.backend = detail::backend_spec(Backend::opencl, o.device, o.threads);  // the method decides the kind (dfg_backend)
    if (spec.method == ms::DfgMethod::sampled) {
        if (o.replicates < 2)
            throw std::invalid_argument("microshadow::bake_dfg: replicates = " + std::to_string(o.replicates) + " (at least 2)");
        spec.plan.replicates = o.replicates;
        spec.plan.samples = ms::round_up_samples(o.samples, o.replicates);
        if (spec.plan.samples / o.replicates > (1u << 24))
            throw std::invalid_argument("microshadow::bake_dfg: samples: at most 2^24 per replicate");
    } else if (o.fast_math) {
        throw std::invalid_argument("microshadow::bake_dfg: fast_math builds the kernel of method sampled; method " + method + " has none");
    }
    spec.plan.seed = o.seed;
    spec.routine.build.fast_math = o.fast_math;
    spec.command_line = "microshadow::bake_dfg (library " MICROSHADOW_VERSION ")";
    ms::validate(spec);
    data->result = detail::run_with_progress(progress, [&](const auto& report) {
        ms::DfgBakeCallbacks callbacks;
        callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { report(done, total); };
        return ms::bake_dfg(spec, callbacks);
    });
    data->metadata = ms::dfg_metadata(spec, data->result);
    return DfgLut(std::move(data));
}

std::uint32_t DfgLut::n_dot_v_count() const { return data_->result.width; }
std::uint32_t DfgLut::roughness_count() const { return data_->result.height; }

std::vector<double> DfgLut::n_dot_v_values() const {
    std::vector<double> out;
    for (std::uint32_t x = 0; x < data_->result.width; ++x) {
        // The texel's NdotV before the grazing clamp (kMinNdotV), as the axis states it.
        const double a = data_->spec.n_dot_v.value(x);
        out.push_back(data_->spec.parameterization == ms::DfgParameterization::sqrt_n_dot_v ? a * a : a);
    }
    return out;
}
std::vector<double> DfgLut::roughness_values() const { return data_->spec.roughness.values(); }

std::vector<std::string> DfgLut::channels() const {
    std::vector<std::string> out;
    for (const ms::DfgChannel c : data_->result.channels) out.emplace_back(ms::to_string(c));
    return out;
}

namespace {
const ms::Estimate& channel_estimate(const ms::dfg::DfgValue& v, ms::DfgChannel c) {
    switch (c) {
        case ms::DfgChannel::scale: return v.scale;
        case ms::DfgChannel::bias: return v.bias;
        case ms::DfgChannel::albedo: return v.albedo;
        case ms::DfgChannel::sheen: return v.sheen;
    }
    return v.scale;
}
}  // namespace

std::vector<double> DfgLut::values() const {
    std::vector<double> out;
    out.reserve(data_->result.values.size() * data_->result.channels.size());
    for (const ms::dfg::DfgValue& v : data_->result.values)
        for (const ms::DfgChannel c : data_->result.channels) out.push_back(channel_estimate(v, c).term);
    return out;
}

std::vector<double> DfgLut::std_errors() const {
    std::vector<double> out;
    out.reserve(data_->result.values.size() * data_->result.channels.size());
    for (const ms::dfg::DfgValue& v : data_->result.values)
        for (const ms::DfgChannel c : data_->result.channels) out.push_back(channel_estimate(v, c).std_error);
    return out;
}

std::string DfgLut::metadata_json() const { return data_->metadata.dump(); }

void DfgLut::save(const std::string& path, bool half, const std::string& symbol) const {
    ms::check_dfg_lut_output(path, data_->result.channels, symbol);
    ms::write_dfg_lut(path, data_->result, data_->metadata, half, symbol);
}

}  // namespace microshadow
