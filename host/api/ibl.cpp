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
    if (o.replicates < 2)
        throw std::invalid_argument("microshadow::bake_dfg: replicates = " + std::to_string(o.replicates) + " (at least 2)");
    spec.plan.replicates = o.replicates;
    spec.plan.seed = o.seed;
    spec.plan.samples = ms::round_up_samples(o.samples, o.replicates);
    if (spec.plan.samples / o.replicates > (1u << 24))
        throw std::invalid_argument("microshadow::bake_dfg: samples: at most 2^24 per replicate");
    // The oracle backend is the quadrature oracle, as the CLI's --backend oracle spells it.
    spec.method = o.backend == Backend::oracle ? ms::DfgMethod::quadrature : ms::DfgMethod::sampled;
    spec.device = o.device;
    spec.routine.build.fast_math = o.fast_math;
    if (o.backend == Backend::oracle && o.fast_math) throw std::invalid_argument("microshadow::bake_dfg: fast_math builds kernels; the oracle has none");
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
std::vector<double> DfgLut::n_dot_v_values() const { return data_->spec.n_dot_v.values(); }
std::vector<double> DfgLut::roughness_values() const { return data_->spec.roughness.values(); }

std::vector<double> DfgLut::values() const {
    std::vector<double> out;
    out.reserve(data_->result.values.size() * 3);
    for (const ms::dfg::DfgValue& v : data_->result.values)
        for (const ms::Estimate* e : {&v.scale, &v.bias, &v.albedo}) out.push_back(e->term);
    return out;
}

std::vector<double> DfgLut::std_errors() const {
    std::vector<double> out;
    out.reserve(data_->result.values.size() * 3);
    for (const ms::dfg::DfgValue& v : data_->result.values)
        for (const ms::Estimate* e : {&v.scale, &v.bias, &v.albedo}) out.push_back(e->std_error);
    return out;
}

std::string DfgLut::metadata_json() const { return data_->metadata.dump(); }

void DfgLut::save(const std::string& path, bool half) const {
    ms::check_dfg_lut_format(path);
    ms::write_dfg_lut(path, data_->result, data_->metadata, half);
}

}  // namespace microshadow
