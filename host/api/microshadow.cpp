// The public facade (include/microshadow/): translates its standard-library types into the jobs'
// specs and back. Everything numeric happens in the layers below (jobs/eval, jobs/bake, lut/).
#include "microshadow/microshadow.hpp"

#include <algorithm>
#include <filesystem>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "api/facade.hpp"
#include "core/query.hpp"
#include "core/types.hpp"
#include "device/runtime.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "jobs/bake.hpp"
#include "jobs/compare.hpp"
#include "jobs/eval.hpp"
#include "lut/exr_lut.hpp"
#include "lut/formats/lut_formats.hpp"
#include "lut/formats/lut_reader.hpp"
#include "lut/lookup.hpp"
#include <nlohmann/json.hpp>
#include "jobs/repr_run.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"
#include "sampling/point_set.hpp"

namespace microshadow {

struct Lut::Data {
    ms::LutLookup lookup;
};

namespace detail {

ms::AoWeighting to_ms(AoWeighting w) { return w == AoWeighting::cosine ? ms::AoWeighting::cosine : ms::AoWeighting::uniform; }
ms::Sequence to_ms(Sequence s) { return s == Sequence::sobol ? ms::Sequence::sobol : ms::Sequence::random; }

ms::TermOptions term_options(AoWeighting weighting, Form form) {
    ms::TermOptions t;
    t.ao_weighting = to_ms(weighting);
    t.form = form == Form::height_correlated ? ms::Form::height_correlated : ms::Form::uncorrelated;
    return t;
}

ms::schedule::BackendSpec backend_spec(Backend backend, const std::string& device, unsigned threads) {
    return ms::schedule::BackendSpec::parse(backend == Backend::oracle ? "oracle" : "opencl", device, threads);
}

std::unique_ptr<ms::TermBackend> make_backend(Backend backend, const std::string& device, bool fast_math) {
    ms::OpenClBackendConfig config;
    config.build.fast_math = fast_math;
    return ms::make_term_backend(backend_spec(backend, device), config);
}

}  // namespace detail

namespace {

ms::TermOptions term_options(const SamplingOptions& o) { return detail::term_options(o.ao_weighting, o.form); }

void check_replicates(std::uint32_t replicates, const char* where) {
    if (replicates < 2)
        throw std::invalid_argument(std::string(where) + ": replicates = " + std::to_string(replicates) +
                                    " (at least 2: the standard error comes from their spread)");
}

std::unique_ptr<ms::TermBackend> make_backend(const SamplingOptions& o) {
    return detail::make_backend(o.backend, o.device, o.fast_math);
}

// A NaN input would make every filter and blend weight NaN, and the lookup would then report it as an
// unbaked texel: refused here, by name, as bad input. (Infinities clamp like any value off the axes.)
void check_lookup_inputs(double visibility, double n_dot_l, double n_dot_v, double roughness, double azimuth) {
    const std::pair<const char*, double> inputs[] = {
        {"visibility", visibility}, {"n_dot_l", n_dot_l}, {"n_dot_v", n_dot_v}, {"roughness", roughness},
        {"relative_azimuth_deg", azimuth}};
    for (const auto& [name, value] : inputs)
        if (std::isnan(value)) throw std::invalid_argument(std::string("lookup: ") + name + " = nan: not a number");
}

Lut make_lut(ms::LutFile file) {
    return Lut(std::make_shared<const Lut::Data>(Lut::Data{ms::LutLookup(std::move(file))}));
}

}  // namespace

std::string version() { return MICROSHADOW_VERSION; }

std::vector<Estimate> evaluate(const std::vector<Query>& queries, const SamplingOptions& options, const Progress& progress) {
    if (options.method == Method::sampled) check_replicates(options.replicates, "microshadow::evaluate");
    std::vector<ms::Query> qs;
    qs.reserve(queries.size());
    for (const Query& q : queries)
        qs.push_back({q.visibility, q.alpha_x, q.alpha_y, {q.wi.x, q.wi.y, q.wi.z}, {q.wo.x, q.wo.y, q.wo.z}});
    ms::SamplingPlan plan;
    plan.samples = ms::round_up_samples(options.samples, options.replicates);
    plan.replicates = options.replicates;
    plan.seed = options.seed;
    plan.sequence = detail::to_ms(options.sequence);
    // What `microshadow eval` builds from the same options (cli/common.cpp: SamplingOptions::plan).
    plan.tolerance = options.tolerance;
    plan.single_precision = options.exact_float;
    if (options.method == Method::exact) {
        plan.method = ms::Method::exact;
        if (plan.tolerance == 0) plan.tolerance = ms::exact::kDefaultTolerance;
        ms::exact_term::validate_tolerance(plan.tolerance);
    }
    auto backend = make_backend(options);
    const std::vector<ms::Estimate> got = detail::run_with_progress(progress, [&](const auto& report) {
        return ms::evaluate(*backend, qs, term_options(options), plan, nullptr,
                            [&](std::size_t done, std::size_t total) { report(done, total); });
    });
    std::vector<Estimate> out;
    out.reserve(got.size());
    for (const ms::Estimate& e : got) out.push_back({e.term, e.std_error});
    return out;
}

Roughness Roughness::from_alpha(double alpha) { return Roughness(std::sqrt(alpha)); }

Query isotropic_query(double visibility, double n_dot_l, double n_dot_v, Roughness roughness, double relative_azimuth_deg) {
    // The sweeps' directions (jobs/sweep/points.cpp: to_query) with phi_i = 0, so that the same
    // parameters give the same query bits here and in a sweep.
    constexpr double kDegree = M_PI / 180.0;
    auto direction = [](double cos_theta, double phi) {
        const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
        return Direction{s * std::cos(phi), s * std::sin(phi), cos_theta};
    };
    Query q;
    q.visibility = visibility;
    q.alpha_x = q.alpha_y = roughness.alpha();
    q.wi = direction(n_dot_v, 0.0);
    q.wo = direction(n_dot_l, relative_azimuth_deg * kDegree);
    return q;
}

Lut bake(const BakeOptions& options, const Progress& progress) {
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
    // The axes, texel convention and azimuth policy as `microshadow bake` sets them (cli/cmd_bake.cpp).
    const ms::TexelConvention texel = ms::parse_texel_convention(options.texel);
    spec.visibility.texel = spec.n_dot_l.texel = texel;
    if (layout != ms::LutLayout::seed_2d) spec.n_dot_v.texel = texel;
    auto set_range = [&](ms::LutAxis& axis, const std::vector<double>& range) {
        if (range.empty()) return;
        if (layout != ms::LutLayout::custom)
            throw std::invalid_argument("microshadow::bake: " + axis.name + "_range applies to the custom layout");
        if (range.size() != 2) throw std::invalid_argument("microshadow::bake: " + axis.name + "_range takes {min, max}");
        axis.min = range[0];
        axis.max = range[1];
    };
    set_range(spec.visibility, options.visibility_range);
    set_range(spec.n_dot_l, options.n_dot_l_range);
    set_range(spec.n_dot_v, options.n_dot_v_range);
    if (options.azimuth == "mean") {
        spec.azimuth_mean = true;
    } else {
        std::size_t used = 0;
        double degrees = 0;
        try {
            degrees = std::stod(options.azimuth, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != options.azimuth.size() || options.azimuth.empty())
            throw std::invalid_argument("microshadow::bake: azimuth must be 'mean' or degrees in [0, 180], not '" +
                                        options.azimuth + "'");
        spec.azimuth_mean = false;
        spec.azimuth_degrees = degrees;
    }
    spec.max_batches = options.max_batches;
    spec.sequence = detail::to_ms(o.sequence);
    spec.exact_single_precision = o.exact_float;
    spec.build.fast_math = o.fast_math;
    spec.term = term_options(o);
    spec.replicates = o.replicates;
    spec.seed = o.seed;
    spec.samples = o.samples ? ms::round_up_samples(o.samples, o.replicates) : 0;
    spec.tolerance = options.tolerance;
    if (o.method == Method::exact) {
        spec.method = ms::Method::exact;
        if (options.tolerance == 0 && o.tolerance > 0) spec.tolerance = o.tolerance;
    }
    spec.backend = detail::backend_spec(o.backend, o.device);
    spec.command_line = "microshadow::bake (library " + version() + ")";
    ms::validate(spec);
    const ms::BakeResult result = detail::run_with_progress(progress, [&](const auto& report) {
        ms::BakeCallbacks callbacks;
        callbacks.progress = [&](std::size_t done, std::size_t total) { report(done, total); };
        return ms::bake_lut(spec, callbacks);
    });
    ms::LutFile file = ms::bake_lut_file(spec, result, ms::bake_metadata(spec, result));
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

std::vector<double> Lut::axis_values(const std::string& axis) const {
    const ms::LutFile& f = data_->lookup.file();
    if (axis == "visibility") return f.visibility().values();
    if (axis == "n_dot_l") return f.n_dot_l().values();
    if (axis == "n_dot_v") return f.n_dot_v().values();
    throw std::invalid_argument("microshadow::Lut::axis_values: axis '" + axis + "' (visibility, n_dot_l or n_dot_v)");
}

std::vector<float> Lut::texels() const {
    const ms::LutFile& f = data_->lookup.file();
    const std::uint32_t channels = std::uint32_t(f.channels.size());
    std::vector<float> out;
    out.reserve(f.data.size());
    for (std::uint32_t k = 0; k < f.n_dot_v().count; ++k)
        for (std::uint32_t j = 0; j < f.n_dot_l().count; ++j)
            for (std::uint32_t i = 0; i < f.visibility().count; ++i)
                for (std::uint32_t c = 0; c < channels; ++c) out.push_back(f.at(c, i, j, k));
    return out;
}

float Lut::texel(std::uint32_t channel, std::uint32_t visibility, std::uint32_t n_dot_l, std::uint32_t n_dot_v) const {
    const ms::LutFile& f = data_->lookup.file();
    if (channel >= f.channels.size() || visibility >= f.visibility().count || n_dot_l >= f.n_dot_l().count || n_dot_v >= f.n_dot_v().count)
        throw std::invalid_argument("microshadow::Lut::texel: index outside the LUT");
    return f.at(channel, visibility, n_dot_l, n_dot_v);
}

double Lut::lookup(double visibility, double n_dot_l, double n_dot_v, Roughness roughness) const {
    check_lookup_inputs(visibility, n_dot_l, n_dot_v, roughness.value, 0);
    return data_->lookup(visibility, n_dot_l, n_dot_v, roughness.value);
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

// --- LookupFile: a LUT or a representation, through the comparators that eval --compare and the sweeps use

struct LookupFile::Data {
    std::string kind;
    std::optional<Lut> lut;
    std::shared_ptr<const ms::repr::Representation> representation;
    std::string metadata_json;
};

LookupFile repr_bake(const ReprBakeOptions& a, const Progress& progress) {
    // The job of `microshadow repr bake` (jobs/repr_run.hpp), run without outputs.
    if (!a.preset.empty()) {
        const ReprBakeOptions d;
        const bool default_layout = a.kind == d.kind && a.visibility_count == d.visibility_count && a.n_dot_l_count == d.n_dot_l_count &&
                                    a.n_dot_v_count == d.n_dot_v_count && a.azimuth_nodes == d.azimuth_nodes &&
                                    a.roughness == d.roughness && a.roughness_count == d.roughness_count &&
                                    a.n_dot_v_warp == d.n_dot_v_warp && a.n_dot_l_warp == d.n_dot_l_warp &&
                                    a.visibility_warp == d.visibility_warp;
        if (!default_layout)
            throw std::invalid_argument("microshadow::repr_bake: preset '" + a.preset +
                                        "' sets the whole layout: leave kind, the counts, roughness and the warps at their defaults");
    }
    const SamplingOptions& o = a.sampling;
    ms::repr::ReprBakeJobSpec spec;
    spec.preset = a.preset;
    spec.kind = a.kind;
    spec.roughness_count = a.roughness_count;
    ms::repr::AzimuthBakeSpec& bake = spec.bake;
    bake.grid.visibility = a.visibility_count;
    bake.grid.n_dot_l = a.n_dot_l_count;
    bake.grid.n_dot_v = a.n_dot_v_count;
    bake.grid.roughness = a.roughness;
    bake.grid.warps.n_dot_v = ms::repr::parse_n_dot_v_warp(a.n_dot_v_warp);
    bake.grid.warps.n_dot_l = ms::repr::parse_n_dot_l_warp(a.n_dot_l_warp);
    bake.grid.warps.visibility = ms::repr::parse_visibility_warp(a.visibility_warp);
    bake.term = term_options(o);
    bake.azimuth_nodes = a.azimuth_nodes;
    if (o.method == Method::sampled) check_replicates(o.replicates, "microshadow::repr_bake");
    bake.plan.samples = ms::round_up_samples(o.samples, o.replicates);
    bake.plan.replicates = o.replicates;
    bake.plan.seed = o.seed;
    bake.plan.sequence = detail::to_ms(o.sequence);
    bake.plan.tolerance = o.tolerance;
    bake.plan.single_precision = o.exact_float;
    if (o.method == Method::exact) {
        bake.plan.method = ms::Method::exact;
        if (bake.plan.tolerance == 0) bake.plan.tolerance = ms::repr::kReferenceTolerance;
        ms::exact_term::validate_tolerance(bake.plan.tolerance);
    }
    bake.command_line = "microshadow::repr_bake (library " + version() + ")";
    spec.make_backend = [&] { return make_backend(o); };
    try {
        ms::repr::validate(spec);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("microshadow::repr_bake: ") + e.what());
    }
    const ms::repr::ReprBakeJobResult result = detail::run_with_progress(progress, [&](const auto& report) {
        ms::repr::ReprBakeJobCallbacks callbacks;
        callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { report(done, total); };
        return ms::repr::run_repr_bake_job(spec, callbacks);
    });
    auto data = std::make_shared<LookupFile::Data>();
    data->representation = result.representation;
    data->kind = result.representation->kind();
    nlohmann::json metadata = result.bake.metadata;
    metadata["kind"] = "representation";
    metadata["representation"] = data->kind;
    data->metadata_json = metadata.dump();
    return LookupFile(std::move(data));
}

std::uint32_t LookupFile::texture_width() const {
    return data_->lut ? data_->lut->visibility_count() : data_->representation->texture_width();
}
std::uint32_t LookupFile::texture_height() const {
    return data_->lut ? data_->lut->n_dot_l_count() : data_->representation->texture_height();
}
std::uint32_t LookupFile::texture_depth() const {
    return data_->lut ? data_->lut->n_dot_v_count() : data_->representation->texture_depth();
}
std::vector<float> LookupFile::texture() const {
    return data_->lut ? data_->lut->texels() : data_->representation->texels();
}

void LookupFile::save(const std::string& path, bool half) const {
    if (data_->lut) return data_->lut->save(path, half ? "float16" : "");
    ms::OutputSet outputs;
    std::optional<ms::repr::ReprFileOutput> file;
    try {
        file.emplace(outputs, path);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("microshadow::LookupFile::save: ") + e.what());
    }
    file->write(outputs, *data_->representation, half);
    outputs.commit();
}

LookupFile::LookupFile(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::LookupFile: no data");
}

LookupInputs lookup_inputs(const Query& q) {
    const ms::Query query{q.visibility, q.alpha_x, q.alpha_y, {q.wi.x, q.wi.y, q.wi.z}, {q.wo.x, q.wo.y, q.wo.z}};
    ms::validate_query(query);
    const ms::approx::Inputs in = ms::approx::inputs_of(query, ms::AoWeighting::cosine);
    return {in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.relative_azimuth * (180.0 / M_PI)};
}

LookupFile open_file(const std::string& path) {
    auto data = std::make_shared<LookupFile::Data>();
    if (ms::repr::is_representation_file(path)) {
        data->representation = ms::repr::open_representation(path);
        data->kind = data->representation->kind();
        data->metadata_json = ms::lutfmt::read_file_metadata(path).dump();
    } else {
        data->lut = open_lut(path);
        data->kind = "lut";
        data->metadata_json = data->lut->metadata_json();
    }
    return LookupFile(std::move(data));
}

std::string LookupFile::kind() const { return data_->kind; }
bool LookupFile::keeps_azimuth() const { return data_->representation != nullptr; }
std::string LookupFile::metadata_json() const { return data_->metadata_json; }

const Lut& LookupFile::lut() const {
    if (!data_->lut) throw std::logic_error("microshadow::LookupFile::lut: the file is a " + data_->kind + " representation");
    return *data_->lut;
}

double LookupFile::lookup(double visibility, double n_dot_l, double n_dot_v, Roughness roughness,
                          double relative_azimuth_deg) const {
    check_lookup_inputs(visibility, n_dot_l, n_dot_v, roughness.value, relative_azimuth_deg);
    if (data_->lut) return data_->lut->lookup(visibility, n_dot_l, n_dot_v, roughness);
    ms::approx::Inputs in;
    in.visibility = visibility;
    in.n_dot_l = n_dot_l;
    in.n_dot_v = n_dot_v;
    in.roughness = roughness.value;
    in.relative_azimuth = relative_azimuth_deg * (M_PI / 180.0);
    return (*data_->representation)(in);
}

}  // namespace microshadow
