// The public facade (include/microshadow/): translates its standard-library types into the jobs'
// specs and back. Everything numeric happens in the layers below (jobs/eval, jobs/bake, lut/).
#include "microshadow/microshadow.hpp"

#include <stdexcept>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "lut/exr_lut.hpp"
#include "lut/formats/lut_formats.hpp"
#include "lut/lookup.hpp"
#include "sampling/point_set.hpp"

namespace microshadow {

struct Lut::Data {
    ms::sweep::LutLookup lookup;
};

namespace {


ms::TermOptions term_options(const SamplingOptions& o) {
    ms::TermOptions t;
    t.ao_weighting = o.ao_weighting == AoWeighting::cosine ? ms::AoWeighting::cosine : ms::AoWeighting::uniform;
    t.form = o.form == Form::height_correlated ? ms::Form::height_correlated : ms::Form::uncorrelated;
    return t;
}

void check_replicates(std::uint32_t replicates, const char* where) {
    if (replicates < 2)
        throw std::invalid_argument(std::string(where) + ": replicates = " + std::to_string(replicates) +
                                    " (at least 2: the standard error comes from their spread)");
}

std::unique_ptr<ms::TermBackend> make_backend(const SamplingOptions& o) {
    if (o.backend == Backend::oracle) return ms::make_oracle_backend();
    return ms::make_opencl_backend(ms::ocl::select_devices(o.device));
}

Lut make_lut(ms::LutFile file) {
    return Lut(std::make_shared<const Lut::Data>(Lut::Data{ms::sweep::LutLookup(std::move(file))}));
}

}  // namespace

std::string version() { return MICROSHADOW_VERSION; }

std::vector<Estimate> evaluate(const std::vector<Query>& queries, const SamplingOptions& options) {
    if (options.method == Method::sampled) check_replicates(options.replicates, "microshadow::evaluate");
    std::vector<ms::Query> qs;
    qs.reserve(queries.size());
    for (const Query& q : queries)
        qs.push_back({q.visibility, q.alpha_x, q.alpha_y, {q.wi.x, q.wi.y, q.wi.z}, {q.wo.x, q.wo.y, q.wo.z}});
    ms::SamplingPlan plan;
    plan.samples = ms::round_up_samples(options.samples, options.replicates);
    plan.replicates = options.replicates;
    plan.seed = options.seed;
    if (options.method == Method::exact) {
        plan.method = ms::Method::exact;
        plan.tolerance = options.tolerance > 0 ? options.tolerance : 1e-10;
    }
    auto backend = make_backend(options);
    const std::vector<ms::Estimate> got = ms::evaluate(*backend, qs, term_options(options), plan);
    std::vector<Estimate> out;
    out.reserve(got.size());
    for (const ms::Estimate& e : got) out.push_back({e.term, e.std_error});
    return out;
}

Lut bake(const BakeOptions& options) {
    const SamplingOptions& o = options.sampling;
    if (o.method == Method::sampled) check_replicates(o.replicates, "microshadow::bake");
    const ms::LutLayout layout = ms::parse_lut_layout(options.layout);
    ms::BakeSpec spec = ms::default_bake_spec(layout, options.size);
    if (options.visibility_count) spec.visibility.count = options.visibility_count;
    if (options.n_dot_l_count) spec.n_dot_l.count = options.n_dot_l_count;
    if (options.n_dot_v_count) spec.n_dot_v.count = options.n_dot_v_count;
    if (!options.roughness.empty()) {
        if (layout != ms::LutLayout::custom)
            throw std::invalid_argument("microshadow::bake: roughness applies to the custom layout (the seeds fix theirs)");
        spec.roughness = options.roughness;
    }
    spec.term = term_options(o);
    spec.replicates = o.replicates;
    spec.seed = o.seed;
    spec.samples = o.samples ? ms::round_up_samples(o.samples, o.replicates) : 0;
    spec.tolerance = options.tolerance;
    if (o.method == Method::exact) {
        spec.method = ms::Method::exact;
        if (options.tolerance == 0 && o.tolerance > 0) spec.tolerance = o.tolerance;
    }
    spec.device = o.device;
    spec.oracle = o.backend == Backend::oracle;
    spec.command_line = "microshadow::bake (library " + version() + ")";
    ms::validate(spec);
    const ms::BakeResult result = ms::bake_lut(spec);
    // The channels as the CLI's bake records them: R, G, B, A by increasing index, isotropic alpha.
    std::vector<ms::LutChannel> channels;
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < spec.roughness.size(); ++c) {
        const double r = spec.roughness[c];
        channels.push_back({names[c], r, r * r, r * r});
    }
    ms::LutFile file = ms::lutfmt::make_lut_file({spec.visibility, spec.n_dot_l, spec.n_dot_v}, channels, result.value,
                                                  ms::bake_metadata(spec, result));
    // The error budget a written file would record (sampling + azimuth quadrature, no quantisation).
    ms::lutfmt::add_error_budget(file.metadata, file.data, ms::lutfmt::PixelEncoding::float32);
    return make_lut(std::move(file));
}

Lut open_lut(const std::string& path) { return make_lut(ms::read_lut(path)); }

Lut::Lut(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::Lut: no data");
}

std::uint32_t Lut::visibility_count() const { return data_->lookup.file().visibility().count; }
std::uint32_t Lut::n_dot_l_count() const { return data_->lookup.file().n_dot_l().count; }
std::uint32_t Lut::n_dot_v_count() const { return data_->lookup.file().n_dot_v().count; }

std::vector<double> Lut::roughness() const {
    std::vector<double> r;
    for (const auto& c : data_->lookup.file().channels) r.push_back(c.roughness);
    return r;
}

float Lut::texel(std::uint32_t channel, std::uint32_t visibility, std::uint32_t n_dot_l, std::uint32_t n_dot_v) const {
    const ms::LutFile& f = data_->lookup.file();
    if (channel >= f.channels.size() || visibility >= f.visibility().count || n_dot_l >= f.n_dot_l().count || n_dot_v >= f.n_dot_v().count)
        throw std::invalid_argument("microshadow::Lut::texel: index outside the LUT");
    return f.at(channel, visibility, n_dot_l, n_dot_v);
}

double Lut::lookup(double visibility, double n_dot_l, double n_dot_v, double roughness) const {
    return data_->lookup(visibility, n_dot_l, n_dot_v, roughness);
}

double Lut::max_total_error() const {
    const auto& m = data_->lookup.file().metadata;
    return m.is_object() && m.contains("max_total_error") && m.at("max_total_error").is_number() ? m.at("max_total_error").get<double>() : 0.0;
}

std::string Lut::metadata_json() const { return data_->lookup.file().metadata.dump(); }

void Lut::save(const std::string& path, const std::string& encoding) const {
    const ms::lutfmt::LutOutput output = ms::lutfmt::resolve_lut_output(path, "", encoding, false);
    ms::lutfmt::write_lut_output(path, data_->lookup.file(), output);
}

}  // namespace microshadow
