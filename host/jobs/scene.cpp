#include "jobs/scene.hpp"

#include "integrands/exact_term/exact_term_integrand.hpp"
#include "exact/exact_term.hpp"
#include "jobs/area.hpp"
#include "integrands/area_light/light_geometry.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "analytic/part1_terms.hpp"
#include "core/cone.hpp"
#include "io/atomic_file.hpp"
#include "io/text.hpp"
#include "platform/files.hpp"
#include "jobs/bake.hpp"
#include "jobs/cache_keys.hpp"
#include "jobs/compare.hpp"
#include "lut/formats/lut_formats.hpp"
#include "lut/lookup.hpp"
#include "scene/false_colour.hpp"
#include "scene/image_io.hpp"
#include "core/digest.hpp"
#include "schedule/item_bytes.hpp"

namespace ms::scene {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct KeyHash {
    std::size_t operator()(const DedupKey& k) const {
        std::uint64_t h = kFnv1aOffset;
        for (std::int64_t v : {k.ax, k.ay, k.cone, k.tv, k.tl, k.pv, k.pl}) {
            h ^= std::uint64_t(v) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
            h *= 1099511628211ULL;
        }
        return std::size_t(h);
    }
};

double seconds_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// One approximation of the term per pixel.
struct Comparator {
    std::string name;
    bool is_lut = false;
    analytic::AnalyticTerm term{};
    std::shared_ptr<LutLookup> lut;
    // A comparator file (a LUT or a representation that keeps the azimuth, opened as eval --compare and
    // sweeps open them): it reads the pixel's relative azimuth too.
    std::shared_ptr<compare::Comparator> file;
    // Scenes with area lights: the exact point term at the light's centre, and the tap approximation
    // with the exact point term at every tap (for directional and point lights both are the exact point
    // term of the light's one direction).
    enum class Builtin { none, centre_exact, taps_exact } builtin = Builtin::none;
    // The file's or seed LUT's domain (none for part 1's formulas).
    std::optional<LookupDomain> domain() const {
        if (file) return file->domain();
        if (lut) return lut->domain();
        return std::nullopt;
    }
};

std::shared_ptr<LutLookup> bake_seed(LutLayout layout, const SceneDescription& d, TermBackend& backend) {
    BakeSpec spec = default_bake_spec(layout, d.comparators.lut_size);
    spec.samples = d.comparators.lut_samples;
    spec.term.ao_weighting = d.ao_weighting;
    spec.term.form = d.sampling.form;
    spec.seed = d.sampling.seed;
    spec.build = backend.config().build;
    validate(spec);
    const BakeResult r = bake_lut(spec, backend.scheduler());
    return std::make_shared<LutLookup>(bake_lut_file(spec, r, bake_metadata(spec, r)));
}

// The point term of the exact evaluator for the built-in comparators (its error, ~1e-6, is far below the
// approximations' errors it is there to show).
constexpr double kBuiltinTolerance = 1e-6;

double exact_point(const Query& q, AoWeighting w) {
    if (!(q.wo.z > 0)) return 0.0;
    return exact::exact_term(q, w, kBuiltinTolerance).term;
}

double comparator_value(const Comparator& c, const PixelSurface& p, const LightQuery& q, AoWeighting w) {
    if (c.builtin != Comparator::Builtin::none) return q.status == PixelStatus::shaded ? exact_point(q.query, w) : 0.0;
    const double n_dot_l = std::clamp(q.n_dot_l, -1.0, 1.0), n_dot_v = std::clamp(q.n_dot_v, 0.0, 1.0);
    if (c.file) {
        approx::Inputs in;
        in.visibility = p.visibility;
        in.n_dot_l = std::max(0.0, n_dot_l);
        in.n_dot_v = n_dot_v;
        in.roughness = p.roughness;
        in.weighting = w;
        // Isotropic pixels carry the relative azimuth; an anisotropic pixel's is that of its tangent-frame
        // query's projections (the same angle, measured in the tangent frame).
        in.relative_azimuth = q.azimuth;
        // An isotropic pixel: V at azimuth 0 and L at the relative azimuth (the frame's azimuth is free).
        in.light_azimuth = q.azimuth;
        in.alpha_x = p.alpha_x;
        in.alpha_y = p.alpha_y;
        if (p.anisotropic && q.status == PixelStatus::shaded) {
            // The tangent-frame query gives the anisotropic lookup what it reads: alpha_x along the
            // tangent, and V's and L's azimuths measured from it (not only their difference).
            const approx::Inputs t = approx::inputs_of(q.query, w);
            in.relative_azimuth = t.relative_azimuth;
            in.view_azimuth = t.view_azimuth;
            in.light_azimuth = t.light_azimuth;
        }
        return (*c.file)(in);
    }
    if (c.is_lut) return (*c.lut)(p.visibility, std::max(0.0, n_dot_l), n_dot_v, p.roughness);
    analytic::AnalyticInputs in;
    in.visibility = p.visibility;
    in.n_dot_l = n_dot_l;
    in.n_dot_v = n_dot_v;
    in.roughness = analytic::activision_roughness_from_alpha(std::sqrt(p.alpha_x * p.alpha_y));
    in.ao_weighting = w;
    return analytic::evaluate(c.term, in);
}

// The tap approximation of an area light with the exact point term at every tap (jobs/area.hpp).
double area_taps_term(const area::AreaQuery& q, AoWeighting w) {
    const std::vector<area::Tap> taps = q.light.shape == area::LightShape::sphere ? area::sphere_taps(q) : area::rect_taps(q);
    double num = 0, den = 0;
    for (const area::Tap& t : taps) {
        if (!(t.weight > 0)) continue;
        Query point;
        point.visibility = q.visibility;
        point.alpha_x = q.alpha_x;
        point.alpha_y = q.alpha_y;
        point.wi = q.wi;
        point.wo = t.wo;
        num += t.weight * exact_point(point, w);
        den += t.weight;
    }
    return den > 0 ? num / den : 0.0;
}

// Int_light f cos dw of a query no sampling pass estimated (its term was an exact rule's): the light's
// sampler (integrands/area_light/light_geometry.hpp) on the midpoints of a 64 x 64 grid.
double lobe_integral_estimate(const area::AreaQuery& query) {
    const area::AreaQuery q = area::normalised(query);
    constexpr int kSide = 64;
    double sum = 0;
    for (int a = 0; a < kSide; ++a)
        for (int b = 0; b < kSide; ++b) sum += area::sample_light(q, (a + 0.5) / kSide, (b + 0.5) / kSide).weight;
    return sum / (kSide * kSide);
}

int band_of(double roughness) { return std::min(3, int(roughness * 4)); }
const char* kBandNames[4] = {"roughness 0-0.25", "roughness 0.25-0.5", "roughness 0.5-0.75", "roughness 0.75-1"};

}  // namespace

double student_t_999(std::uint32_t r) {
    switch (r) {
        case 8: return 5.408;   // 7 degrees of freedom
        case 16: return 4.073;  // 15
        case 32: return 3.633;  // 31
        case 64: return 3.460;  // 63
    }
    throw std::invalid_argument("sampling.replicates must be 8, 16, 32 or 64 (got " + std::to_string(r) + ")");
}

DedupKey dedup_key(const Query& q, AoWeighting weighting, double step) {
    DedupKey k;
    k.ax = std::llround(std::log(q.alpha_x) / step);
    k.ay = std::llround(std::log(q.alpha_y) / step);
    const double s = step * std::exp(0.5 * double(k.ax + k.ay) * step);
    k.cone = std::llround(std::acos(std::clamp(cone_cos_theta(q.visibility, weighting), -1.0, 1.0)) / s);
    k.tv = std::llround(std::acos(std::clamp(q.wi.z, -1.0, 1.0)) / s);
    k.tl = std::llround(std::acos(std::clamp(q.wo.z, -1.0, 1.0)) / s);
    const double pv = std::atan2(q.wi.y, q.wi.x), pl = std::atan2(q.wo.y, q.wo.x);
    if (k.ax == k.ay) {  // isotropic: only the relative azimuth, folded into [0, pi]
        double d = std::fabs(std::remainder(pl - pv, 2 * kPi));
        k.pv = 0;
        k.pl = std::llround(d / s);
    } else {
        k.pv = std::llround(pv / s);
        k.pl = std::llround(pl / s);
    }
    return k;
}

Query dedup_query(const DedupKey& k, AoWeighting weighting, double step) {
    Query q;
    q.alpha_x = std::exp(double(k.ax) * step);
    q.alpha_y = std::exp(double(k.ay) * step);
    const double s = step * std::exp(0.5 * double(k.ax + k.ay) * step);
    const double cos_t = std::cos(std::min(double(k.cone) * s, kPi / 2));
    q.visibility = std::clamp(weighting == AoWeighting::cosine ? 1 - cos_t * cos_t : 1 - cos_t, 0.0, 1.0);
    const double tv = std::min(double(k.tv) * s, std::acos(1e-6)), tl = std::min(double(k.tl) * s, kPi / 2);
    const double pv = double(k.pv) * s, pl = std::min(double(k.pl) * s, k.ax == k.ay ? kPi : 1e300);
    q.wi = {std::sin(tv) * std::cos(pv), std::sin(tv) * std::sin(pv), std::cos(tv)};
    q.wo = {std::sin(tl) * std::cos(pl + (k.ax == k.ay ? pv : 0)), std::sin(tl) * std::sin(pl + (k.ax == k.ay ? pv : 0)),
            std::cos(tl)};
    return q;
}

namespace {

constexpr std::uint32_t kNoKey = 0xffffffffu, kExact = 0xfffffffeu;
constexpr std::uint8_t kUnlit = 0xff;

// Everything a tile's computation reads, set up once per process: every shard, MPI rank and merge of a
// run sets up the same job from the same inputs and options.
struct SceneJob {
    SceneJob(const SceneInputs& in, TermBackend& b, const SceneRunOptions& o) : inputs(in), d(in.description()), backend(b), options(o) {}
    const SceneInputs& inputs;
    const SceneDescription& d;
    TermBackend& backend;
    const SceneRunOptions& options;
    Method method = Method::exact;
    double tol = 0, step = 0;  // the per-pixel tolerance E and the key grid's step q E (0: no deduplication)
    AoWeighting w = AoWeighting::cosine;
    std::size_t n = 0;         // pixels
    std::size_t tile = 1, tiles_per_light = 0;
    std::vector<Comparator> comparators;
    std::map<int, std::size_t> material_group;  // material index -> its statistics group
    std::size_t group_count = 0;
    TermOptions term_options;

    void progress(const std::string& phase, std::size_t done, std::size_t total) const {
        if (options.progress) options.progress(phase, done, total);
    }
    // The factor of a light's error bound: Student t of the replicates, or 1 for the exact method's
    // point term (its std_error is its estimated error itself); area lights' outer sampling always has it.
    double bound_factor(const Light& light) const {
        if (light.is_area()) return student_t_999(d.sampling.replicates);
        return method == Method::exact ? 1.0 : student_t_999(d.sampling.replicates);
    }
};

// The tiles of `pixels` pixels: sampling.tile_pixels at a time (0: the whole image at once).
std::size_t tile_size(const SceneDescription& d, std::size_t pixels) {
    return d.sampling.tile_pixels ? std::size_t(d.sampling.tile_pixels) : std::max<std::size_t>(pixels, 1);
}

// The method and tolerance the options and the description give.
void resolve_method(SceneJob& job, SceneResult& result) {
    const SceneRunOptions& options = job.options;
    const SceneDescription& d = job.d;
    job.method = options.method_given ? options.method : d.sampling.method;
    result.method = job.method;
    result.tolerance = options.tolerance > 0 ? options.tolerance
                       : (d.sampling.tolerance_given || !options.method_given) ? d.sampling.tolerance
                                                                              : default_scene_tolerance(job.method);
    if (job.method == Method::exact) exact_term::validate_tolerance(result.tolerance);
    job.tol = result.tolerance;
    job.step = options.skip ? d.sampling.dedup_step * job.tol : 0;
    job.w = d.ao_weighting;
    job.n = job.inputs.pixels();
    job.tile = tile_size(d, job.n);
    job.tiles_per_light = (job.n + job.tile - 1) / job.tile;
    job.term_options.form = d.sampling.form;
    job.term_options.ao_weighting = job.w;
}

// The comparators: part 1's analytic terms, the built-in exact ones of scenes with area lights, the
// seed LUTs (baked here) and the comparator files. Their files are opened, and every output name known
// and checked, before the seed LUTs are baked: a missing LUT or an unwritable destination is refused
// before any work.
void make_comparators(SceneJob& job, SceneResult& result) {
    const SceneDescription& d = job.d;
    const SceneRunOptions& options = job.options;
    std::vector<Comparator>& comparators = job.comparators;
    for (const auto& name : d.comparators.analytic) {
        Comparator c;
        c.name = name;
        try {
            c.term = analytic::parse_analytic_term(name);
        } catch (const std::invalid_argument& e) {
            throw SceneError(d.source + ": comparators.analytic: " + e.what());
        }
        comparators.push_back(c);
    }
    std::vector<std::string> lut_files = d.comparators.luts;
    lut_files.insert(lut_files.end(), options.luts.begin(), options.luts.end());
    std::set<std::string> used;
    // A name is taken with its "_error" layer: `--lut A.exr --lut A_error.exr` must not give the second
    // LUT's approximation the first one's error layer name.
    auto take = [&used](std::string name) {
        while (used.count(name) || used.count(name + "_error")) name += "_";
        used.insert(name);
        used.insert(name + "_error");
        return name;
    };
    for (const auto& c : comparators) take(c.name);
    if (std::any_of(d.lights.begin(), d.lights.end(), [](const Light& l) { return l.is_area(); })) {
        Comparator centre, taps;
        centre.name = take("centre-exact");
        centre.builtin = Comparator::Builtin::centre_exact;
        taps.name = take("taps-exact");
        taps.builtin = Comparator::Builtin::taps_exact;
        comparators.push_back(centre);
        comparators.push_back(taps);
    }
    const std::string seed_3d_name = take("seed-3d-" + std::to_string(d.comparators.lut_size));
    const std::string seed_2d_name = take("seed-2d-" + std::to_string(d.comparators.lut_size));
    std::vector<Comparator> file_comparators;
    for (const auto& f : lut_files) {
        std::shared_ptr<compare::Comparator> file;
        try {
            require_regular_file(f);  // a FIFO would block in open()
            file = std::make_shared<compare::Comparator>(compare::Comparator::open_file(fs::path(f).stem().string(), f));
        } catch (const std::exception& e) {
            throw SceneError(std::string("LUT comparator: ") + e.what());
        }
        std::string name = (file->is_representation() ? "repr-" : "lut-") + fs::path(f).stem().string();
        for (char& ch : name)
            if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_') ch = '_';
        file_comparators.push_back({take(name), true, {}, nullptr, file});
    }
    const bool seed_3d = options.bake_seed_luts && d.comparators.seed_3d, seed_2d = options.bake_seed_luts && d.comparators.seed_2d;
    {
        std::vector<std::string> names;
        for (const auto& c : comparators) names.push_back(c.name);
        if (seed_3d) names.push_back(seed_3d_name);
        if (seed_2d) names.push_back(seed_2d_name);
        for (const auto& c : file_comparators) names.push_back(c.name);
        // Held to the end: the output layers (3 + 2 per comparator per light) and the mask, as floats.
        const std::uint64_t planes = std::uint64_t(d.lights.size()) * (3 + 2 * names.size()) + 1;
        const std::uint64_t bytes = planes * std::uint64_t(job.n) * sizeof(float);
        if (options.memory_limit > 0 && bytes > options.memory_limit)
            throw SceneError(d.source + ": the output images need about " + format_g(double(bytes) / double(1ULL << 30)) + " GiB (" +
                             std::to_string(d.lights.size()) + " light(s) x (3 + 2 x " + std::to_string(names.size()) +
                             " comparators) planes of " + std::to_string(result.width) + " x " + std::to_string(result.height) +
                             " floats), more than the limit of " + format_g(double(options.memory_limit) / double(1ULL << 30)) +
                             " GiB: use fewer lights or comparators, or a smaller image");
        if (options.check_outputs) options.check_outputs(names);
    }
    const auto lut_start = std::chrono::steady_clock::now();
    if (seed_3d) {
        job.progress("baking the seed 3D LUT", 0, 1);
        comparators.push_back({seed_3d_name, true, {}, bake_seed(LutLayout::seed_3d, d, job.backend), nullptr});
    }
    if (seed_2d) {
        job.progress("baking the seed 2D LUT", 0, 1);
        comparators.push_back({seed_2d_name, true, {}, bake_seed(LutLayout::seed_2d, d, job.backend), nullptr});
    }
    for (auto& c : file_comparators) comparators.push_back(std::move(c));
    result.lut_seconds = seconds_since(lut_start);
    for (const auto& c : comparators) result.comparators.push_back(c.name);
}

// Every lit pixel-light's lookup counted against each comparator's domain before any sampling, so
// --strict-domain refuses at no cost (inputs as comparator_value reads them).
void tally_domains(const SceneJob& job, SceneResult& result) {
    const std::vector<Comparator>& comparators = job.comparators;
    std::vector<std::optional<LookupDomain>> domains;
    for (const auto& c : comparators) domains.push_back(c.domain());
    result.domains = domains;
    result.outside_domain.assign(comparators.size(), DomainTally{});
    result.first_outside.assign(comparators.size(), std::string());
    if (std::any_of(domains.begin(), domains.end(), [](const auto& x) { return x.has_value(); }))
        for (const Light& light : job.d.lights)
            for (std::size_t i = 0; i < job.n; ++i) {
                const PixelSurface p = job.inputs.pixel(i);
                const LightQuery q = light_query(p, light);
                if (q.status != PixelStatus::shaded) continue;
                const double l = std::max(0.0, std::clamp(q.n_dot_l, -1.0, 1.0)), v = std::clamp(q.n_dot_v, 0.0, 1.0);
                for (std::size_t k = 0; k < comparators.size(); ++k) {
                    if (!domains[k]) continue;
                    const bool inside = domains[k]->contains(p.visibility, l, v, p.roughness, p.alpha_x, p.alpha_y);
                    result.outside_domain[k].add(inside);
                    if (!inside && result.first_outside[k].empty())
                        result.first_outside[k] = "light " + light.name + ", pixel (" + std::to_string(i % result.width) + ", " +
                                                  std::to_string(i / result.width) + "): " +
                                                  domains[k]->first_outside(p.visibility, l, v, p.roughness, p.alpha_x, p.alpha_y);
                }
            }
    if (job.options.strict_domain)
        for (std::size_t k = 0; k < comparators.size(); ++k)
            if (domains[k]) {
                try {
                    compare::refuse_outside_domain(job.d.source, comparators[k].name, *domains[k], result.outside_domain[k],
                                                   result.first_outside[k]);
                } catch (const std::invalid_argument& e) {
                    throw SceneError(e.what());
                }
            }
}

// The mask layer and the statistics groups: "all", the roughness bands, the materials present.
void mask_and_groups(SceneJob& job, SceneResult& result) {
    result.mask.assign(job.n, 0.0f);
    std::set<int> materials;
    for (std::size_t i = 0; i < job.n; ++i) {
        const PixelSurface p = job.inputs.pixel(i);
        result.mask[i] = p.shaded ? 1.0f : 0.0f;
        if (p.shaded && job.d.has_material) materials.insert(p.material);
    }
    result.groups = {"all"};
    for (const char* b : kBandNames) result.groups.push_back(b);
    for (int m : materials) {
        job.material_group[m] = result.groups.size();
        result.groups.push_back("material " + (m >= 0 && std::size_t(m) < job.d.material_names.size()
                                                   ? job.d.material_names[std::size_t(m)]
                                                   : std::to_string(m)));
    }
    job.group_count = result.groups.size();
    if (std::any_of(job.d.lights.begin(), job.d.lights.end(), [](const Light& l) { return l.is_area(); }))
        result.area_tolerance = job.d.sampling.area_tolerance;
}

// One work item's result: a tile of one light. The layers of its pixels, and for every pixel that
// enters the comparison (accounted) its irradiance and comparator values in double, so the statistics
// are accumulated from the same doubles, in the same order, wherever the tile was computed.
struct TileResult {
    SkipCounts counts;
    double max_error_bound = 0, sampling_seconds = 0, seconds = 0;
    std::vector<float> reference, std_error, weight;  // per pixel of the tile
    std::vector<std::uint8_t> accounted;              // per pixel: 0 not compared, 1 compared (unlit), 2 compared (lit)
    std::vector<double> irradiance;                   // per compared pixel
    std::vector<double> values;                       // per compared pixel, one per comparator
};

void add_counts(SkipCounts& to, const SkipCounts& c) {
    to.pixel_lights += c.pixel_lights;
    to.masked += c.masked;
    to.view_below_horizon += c.view_below_horizon;
    to.light_below_horizon += c.light_below_horizon;
    to.zero_region += c.zero_region;
    to.v_one += c.v_one;
    to.duplicates += c.duplicates;
    to.sampled += c.sampled;
    to.samples_drawn += c.samples_drawn;
    to.samples_final += c.samples_final;
    for (const auto& [samples, queries] : c.final_pass_queries) to.final_pass_queries[samples] += queries;
    to.tolerance_missed += c.tolerance_missed;
}

// A tile's pixel as compared: its irradiance and the comparators' values (values: one per comparator).
void record_pixel(TileResult& r, bool lit, double irradiance, const std::vector<double>& values, std::size_t at) {
    r.accounted[at] = lit ? 2 : 1;
    r.irradiance.push_back(irradiance);
    r.values.insert(r.values.end(), values.begin(), values.end());
}

// Samples the point queries of a tile as passes (samples -> queries). A query whose bound B exceeds the
// tolerance E after N samples is resampled with the smallest power-of-two multiple of N, at least 2 N,
// above N (B / E)^(4/3): the samples the bound needs if the error falls as N^(-3/4) (scrambled nets on
// this integrand fall faster than Monte Carlo's N^(-1/2)), up to max_samples. Measured on the example
// scene: 3.25e9 samples, against 3.59e9 doubling each pass and 4.06e9 predicting at the Monte Carlo rate.
using Passes = std::map<std::uint64_t, std::vector<std::uint32_t>>;
struct PointSampling {
    const SceneJob& job;
    const Light& light;
    const std::vector<Query>& queries;
    std::vector<Estimate>& estimates;
    std::vector<std::uint64_t>& final_samples;
    SkipCounts& c;
    SamplingPlan plan;
    double t = 1;
    std::size_t tile_start = 0, tile_end = 0;

    void run(Passes initial) {
        const double tol = job.tol;
        const std::uint64_t max_samples = job.d.sampling.max_samples;
        Passes pending;  // resampling passes
        while (!initial.empty() || !pending.empty()) {
            const bool first_pass = !initial.empty();
            Passes& from = first_pass ? initial : pending;
            plan.samples = from.begin()->first;
            const std::vector<std::uint32_t> todo = std::move(from.begin()->second);
            from.erase(from.begin());
            std::vector<Query> batch;
            batch.reserve(todo.size());
            for (auto k : todo) batch.push_back(queries[k]);
            EvalStats eval_stats;
            const auto est = evaluate_each(job.backend, batch, std::vector<TermOptions>(batch.size(), job.term_options), plan, &eval_stats,
                                           [&](std::size_t done, std::size_t total) {
                                               // Progress in pixels: first passes move through the tile.
                                               if (first_pass && total)
                                                   job.progress(light.name, tile_start + (tile_end - tile_start) * done / total, job.n);
                                           });
            c.samples_drawn += std::uint64_t(eval_stats.sampled) * plan.samples;
            if (first_pass) {
                // Without skipping, the integrand's own exact answers (zero region and a light below the
                // horizon: exact 0; v = 1) are what was not sampled.
                if (!job.options.skip) {
                    c.zero_region += eval_stats.exact_zero;
                    c.v_one += eval_stats.exact_one;
                }
                c.sampled += eval_stats.sampled;
            }
            for (std::size_t j = 0; j < todo.size(); ++j) {
                estimates[todo[j]] = est[j];
                const double bound = t * est[j].std_error;
                // A query that stops here (exact answers by the integrand count 0 samples).
                const bool sampled_here = est[j].std_error > 0 || !(est[j].term == 0 || est[j].term == 1);
                if (!(bound > tol)) {
                    if (sampled_here) {
                        c.samples_final += plan.samples, ++c.final_pass_queries[plan.samples];
                        final_samples[todo[j]] = plan.samples;
                    }
                    continue;
                }
                if (plan.samples * 2 > max_samples) {
                    c.samples_final += plan.samples, ++c.final_pass_queries[plan.samples];
                    final_samples[todo[j]] = plan.samples;
                    ++c.tolerance_missed;
                    continue;
                }
                const double want = double(plan.samples) * std::pow(bound / tol, 4.0 / 3.0);
                std::uint64_t next = plan.samples * 2;
                while (double(next) < want && next * 2 <= max_samples) next *= 2;
                pending[next].push_back(todo[j]);
            }
        }
    }
};

// Classifies every pixel of a point light's tile (exact answers in double) and keys the rest on the
// grid (dedup_key; a key repeats only within the tile): the distinct queries, and each pixel's key
// (kNoKey: nothing to shade, kExact: answered here).
std::vector<std::uint32_t> classify_point_tile(const SceneJob& job, const Light& light, std::size_t tile_start, std::size_t tile_end,
                                               TileResult& r, std::vector<Query>& queries) {
    SkipCounts& c = r.counts;
    std::vector<std::uint32_t> pixel_key(tile_end - tile_start, kNoKey);
    std::unordered_map<DedupKey, std::uint32_t, KeyHash> keys;
    for (std::size_t i = tile_start; i < tile_end; ++i) {
        std::uint32_t& key = pixel_key[i - tile_start];
        ++c.pixel_lights;
        const PixelSurface p = job.inputs.pixel(i);
        const LightQuery q = light_query(p, light);
        r.weight[i - tile_start] = float(q.irradiance);
        if (q.status == PixelStatus::masked) {
            ++c.masked;
            continue;
        }
        if (q.status == PixelStatus::view_below_horizon) {
            ++c.view_below_horizon;
            continue;
        }
        if (job.options.skip) {
            if (q.status == PixelStatus::light_below_horizon) {
                ++c.light_below_horizon;
                key = kExact;
                continue;
            }
            if (in_zero_region(cone_cos_theta(p.visibility, job.w), q.n_dot_l)) {
                ++c.zero_region;
                key = kExact;
                continue;
            }
            if (p.visibility == 1) {
                ++c.v_one;
                r.reference[i - tile_start] = 1;
                key = kExact;
                continue;
            }
        }
        if (job.step > 0) {
            const DedupKey k = dedup_key(q.query, job.w, job.step);
            const auto [it, inserted] = keys.emplace(k, std::uint32_t(queries.size()));
            if (inserted) queries.push_back(dedup_query(k, job.w, job.step));
            else ++c.duplicates;
            key = it->second;
        } else {
            key = std::uint32_t(queries.size());
            queries.push_back(q.query);
        }
    }
    return pixel_key;
}

// The distinct queries of a tile to the tolerance: by the exact evaluator in one pass, or sampled.
// Neighbour prediction (sampling.predict_stride S > 1, default 8): the queries of a tile are in scan
// order, and neighbouring pixels need similar counts. Every S-th query (a leader) starts at
// min_samples; each other query starts at the smaller of the counts where the leaders before and after
// it stopped, so most skip the passes whose samples the next pass would discard (passes are not nested:
// a pass of N samples is a different net from one of 2N). A query's count is chosen from other queries'
// results, never from its own samples, and its stopping rule is unchanged.
std::vector<Estimate> estimate_point_queries(const SceneJob& job, const Light& light, std::size_t tile_start, std::size_t tile_end,
                                             const std::vector<Query>& queries, double t, SkipCounts& c) {
    std::vector<Estimate> estimates(queries.size());
    if (job.method == Method::exact) {
        SamplingPlan exact_plan;
        exact_plan.method = Method::exact;
        exact_plan.tolerance = job.tol;
        EvalStats eval_stats;
        estimates = evaluate_each(job.backend, queries, std::vector<TermOptions>(queries.size(), job.term_options), exact_plan,
                                  &eval_stats, [&](std::size_t done, std::size_t total) {
                                      if (total) job.progress(light.name, tile_start + (tile_end - tile_start) * done / total, job.n);
                                  });
        c.sampled += eval_stats.sampled;
        if (!job.options.skip) {
            c.zero_region += eval_stats.exact_zero;
            c.v_one += eval_stats.exact_one;
        }
        for (const Estimate& e : estimates)
            if (e.std_error > job.tol) ++c.tolerance_missed;
        return estimates;
    }
    std::vector<std::uint64_t> final_samples(queries.size(), 0);
    PointSampling sampling{job, light, queries, estimates, final_samples, c, SamplingPlan{}, t, tile_start, tile_end};
    sampling.plan.replicates = job.d.sampling.replicates;
    sampling.plan.seed = job.d.sampling.seed;
    const std::uint64_t first = round_up_samples(job.d.sampling.min_samples, sampling.plan.replicates);
    const std::size_t stride = std::max<std::size_t>(1, job.d.sampling.predict_stride);
    Passes leaders, followers;
    for (std::size_t k = 0; k < queries.size(); k += stride) leaders[first].push_back(std::uint32_t(k));
    sampling.run(std::move(leaders));
    for (std::size_t k = 0; k < queries.size(); ++k)
        if (k % stride) {
            // The smaller of the two leaders around it: overshooting costs a whole pass of extra samples,
            // undershooting one smaller discarded pass (measured: min of both 2.85e9 samples on the example
            // scene, the preceding leader alone 2.97e9, every query from min_samples 3.25e9).
            const std::size_t before = k - k % stride, after = before + stride;
            std::uint64_t predicted = final_samples[before];
            if (after < queries.size()) predicted = std::min(predicted, final_samples[after]);
            followers[std::max(first, predicted)].push_back(std::uint32_t(k));
        }
    sampling.run(std::move(followers));
    return estimates;
}

// A tile of a directional or point light: classify and key, estimate the distinct queries, then each
// pixel's reference and comparator values.
void compute_point_tile(const SceneJob& job, const Light& light, std::size_t tile_start, std::size_t tile_end, TileResult& r) {
    const double t = job.bound_factor(light);
    std::vector<Query> queries;
    const std::vector<std::uint32_t> pixel_key = classify_point_tile(job, light, tile_start, tile_end, r, queries);
    const auto sampling_start = std::chrono::steady_clock::now();
    const std::vector<Estimate> estimates = estimate_point_queries(job, light, tile_start, tile_end, queries, t, r.counts);
    r.sampling_seconds += seconds_since(sampling_start);

    std::vector<double> values(job.comparators.size(), 0.0);
    const std::uint32_t width = job.inputs.width();
    for (std::size_t i = tile_start; i < tile_end; ++i) {
        const std::uint32_t key = pixel_key[i - tile_start];
        if (key == kNoKey) continue;
        if (key != kExact) {
            const Estimate& e = estimates[key];
            r.reference[i - tile_start] = float(e.term);
            r.std_error[i - tile_start] = float(e.std_error);
            r.max_error_bound = std::max(r.max_error_bound, t * e.std_error);
        }
        const PixelSurface p = job.inputs.pixel(i);
        const LightQuery q = light_query(p, light);
        const bool lit = q.status == PixelStatus::shaded;
        for (std::size_t k = 0; k < job.comparators.size(); ++k) {
            try {
                values[k] = comparator_value(job.comparators[k], p, q, job.w);
            } catch (const std::domain_error& e) {
                // A LUT of bake --scene refuses lookups outside what it baked or was fitted to. A pixel the
                // light does not reach is no lookup a renderer makes (its weight is 0): 0 there.
                if (lit)
                    throw SceneError("comparator " + job.comparators[k].name + " at pixel (" + std::to_string(i % width) + ", " +
                                     std::to_string(i / width) + "): " + e.what());
                values[k] = 0;
            }
        }
        record_pixel(r, lit, q.irradiance, values, i - tile_start);
    }
}

// A tile of an area light: no key grid (a light adds its shape to every query); each lit pixel's T_area
// is computed to the area tolerance by passes that double the outer samples.
void compute_area_tile(const SceneJob& job, const Light& light, std::size_t tile_start, std::size_t tile_end, TileResult& r) {
    SkipCounts& c = r.counts;
    const double area_tolerance = job.d.sampling.area_tolerance;
    const double t = job.bound_factor(light);
    area::AreaRoutineConfig area_config;
    if (job.method == Method::exact) area_config.inner_term = area::exact_inner_term(job.w, job.tol);
    SamplingPlan plan;
    plan.replicates = job.d.sampling.replicates;
    plan.seed = job.d.sampling.seed;
    std::vector<std::size_t> pixels;
    std::vector<area::AreaQuery> queries;
    std::vector<AreaLightQuery> pixel_queries;
    for (std::size_t i = tile_start; i < tile_end; ++i) {
        ++c.pixel_lights;
        AreaLightQuery a = area_light_query(job.inputs.pixel(i), light);
        if (a.status == PixelStatus::shaded && !(area::max_height(area::normalised(a.query).light) > 0))
            a.status = PixelStatus::light_below_horizon;  // no direction of the light above the horizon: 0
        if (a.status == PixelStatus::masked) ++c.masked;
        else if (a.status == PixelStatus::view_below_horizon) ++c.view_below_horizon;
        else if (a.status == PixelStatus::light_below_horizon) ++c.light_below_horizon;
        else {
            pixels.push_back(i);
            queries.push_back(a.query);
            pixel_queries.push_back(a);
        }
    }
    const auto sampling_start = std::chrono::steady_clock::now();
    std::vector<area::AreaEstimate> estimates(queries.size());
    std::vector<std::size_t> todo(queries.size());
    for (std::size_t k = 0; k < todo.size(); ++k) todo[k] = k;
    // The exact inner term costs ~10 us a direction: it starts at 128 directions a replicate and stops
    // at 2^16 (docs/scenes.md); the joint kernel at min_samples and max_samples.
    const bool exact_inner = bool(area_config.inner_term);
    std::uint64_t samples = exact_inner ? std::uint64_t(plan.replicates) * 128 : round_up_samples(job.d.sampling.min_samples, plan.replicates);
    const std::uint64_t most = exact_inner ? std::min<std::uint64_t>(job.d.sampling.max_samples, 65536) : job.d.sampling.max_samples;
    bool first_pass = true;
    while (!todo.empty()) {
        plan.samples = samples;
        std::vector<area::AreaQuery> batch;
        for (std::size_t k : todo) batch.push_back(queries[k]);
        area::AreaEvalStats st;
        const auto est = area::evaluate_area(job.backend, batch, job.term_options, plan, area_config, &st,
                                             [&](std::size_t done, std::size_t total) {
                                                 if (first_pass && total)
                                                     job.progress(light.name, tile_start + (tile_end - tile_start) * done / total, job.n);
                                             });
        c.samples_drawn += std::uint64_t(st.sampled) * samples;
        if (first_pass) {
            c.sampled += st.sampled;
            c.zero_region += st.zero_region;
            c.v_one += st.visibility_one;
            c.light_below_horizon += st.below_horizon;
        }
        std::vector<std::size_t> next;
        for (std::size_t j = 0; j < todo.size(); ++j) {
            estimates[todo[j]] = est[j];
            const double bound = t * est[j].term.std_error + est[j].inner_error;
            if (!(bound > area_tolerance) || !est[j].sampled || samples * 2 > most) {
                if (est[j].sampled) c.samples_final += samples, ++c.final_pass_queries[samples];
                if (bound > area_tolerance) ++c.tolerance_missed;
                continue;
            }
            next.push_back(todo[j]);
        }
        todo = std::move(next);
        samples *= 2;
        first_pass = false;
    }
    r.sampling_seconds += seconds_since(sampling_start);
    std::vector<double> values(job.comparators.size(), 0.0);
    const std::uint32_t width = job.inputs.width();
    for (std::size_t k = 0; k < pixels.size(); ++k) {
        const std::size_t i = pixels[k];
        const area::AreaEstimate& e = estimates[k];
        const PixelSurface p = job.inputs.pixel(i);
        const AreaLightQuery& a = pixel_queries[k];
        r.reference[i - tile_start] = float(e.term.term);
        // Stored so that t x std_error is the pixel's bound: the outer's replicate error and the inner bound.
        r.std_error[i - tile_start] = float(e.term.std_error + e.inner_error / t);
        r.max_error_bound = std::max(r.max_error_bound, t * e.term.std_error + e.inner_error);
        // The unshadowed contribution: radiance x Int_light f cos, the reference run's estimate of it (a
        // pixel an exact rule answered was not sampled: a light-sampled estimate of its own).
        const double irradiance = light.intensity * (e.sampled ? e.lobe_integral.term : lobe_integral_estimate(a.query));
        r.weight[i - tile_start] = float(irradiance);
        for (std::size_t j = 0; j < job.comparators.size(); ++j) {
            const Comparator& cmp = job.comparators[j];
            if (cmp.builtin == Comparator::Builtin::taps_exact) {
                values[j] = area_taps_term(a.query, job.w);
                continue;
            }
            try {
                values[j] = comparator_value(cmp, p, a.centre, job.w);  // the lookup at the light's centre
            } catch (const std::domain_error& ex) {
                throw SceneError("comparator " + cmp.name + " at pixel (" + std::to_string(i % width) + ", " +
                                 std::to_string(i / width) + "): " + ex.what());
            }
        }
        record_pixel(r, true, irradiance, values, i - tile_start);  // some of the light is above the horizon: lit
    }
}

// Work item `id`: light id / tiles, tile id % tiles.
struct TileOf {
    std::size_t light = 0, start = 0, end = 0;
};
TileOf tile_of(const SceneJob& job, std::uint64_t id) {
    TileOf t;
    t.light = std::size_t(id / job.tiles_per_light);
    t.start = std::size_t(id % job.tiles_per_light) * job.tile;
    t.end = std::min(job.n, t.start + job.tile);
    return t;
}

TileResult compute_tile(const SceneJob& job, std::uint64_t id) {
    const auto start = std::chrono::steady_clock::now();
    const TileOf t = tile_of(job, id);
    const Light& light = job.d.lights[t.light];
    const std::size_t size = t.end - t.start;
    TileResult r;
    r.reference.assign(size, 0.0f);
    r.std_error.assign(size, 0.0f);
    r.weight.assign(size, 0.0f);
    r.accounted.assign(size, 0);
    if (light.is_area()) compute_area_tile(job, light, t.start, t.end, r);
    else compute_point_tile(job, light, t.start, t.end, r);
    job.progress(light.name, t.end, job.n);
    r.seconds = seconds_since(start);
    return r;
}

// The byte form of a tile (schedule/item_bytes.hpp: the numbers bit for bit).
std::string encode_tile(const TileResult& r) {
    schedule::ItemWriter w;
    const SkipCounts& c = r.counts;
    for (std::uint64_t v : {c.pixel_lights, c.masked, c.view_below_horizon, c.light_below_horizon, c.zero_region, c.v_one, c.duplicates,
                            c.sampled, c.samples_drawn, c.samples_final, c.tolerance_missed})
        w.put(v);
    std::vector<std::uint64_t> passes;
    for (const auto& [samples, queries] : c.final_pass_queries) passes.insert(passes.end(), {samples, queries});
    w.put_vector(passes);
    w.put(r.max_error_bound);
    w.put(r.sampling_seconds);
    w.put(r.seconds);
    w.put_vector(r.reference);
    w.put_vector(r.std_error);
    w.put_vector(r.weight);
    w.put_vector(r.accounted);
    w.put_vector(r.irradiance);
    w.put_vector(r.values);
    return w.take();
}

// Reads item `id`'s bytes back; std::runtime_error naming the item when they are not a tile of this job.
TileResult decode_tile(const SceneJob& job, std::uint64_t id, const std::string& payload) {
    const TileOf t = tile_of(job, id);
    const std::string what = "scene: item " + std::to_string(id) + " (light " + job.d.lights[t.light].name + ", pixels " +
                             std::to_string(t.start) + "-" + std::to_string(t.end) + ")";
    schedule::ItemReader in(payload, what);
    TileResult r;
    SkipCounts& c = r.counts;
    for (std::uint64_t* v : {&c.pixel_lights, &c.masked, &c.view_below_horizon, &c.light_below_horizon, &c.zero_region, &c.v_one,
                             &c.duplicates, &c.sampled, &c.samples_drawn, &c.samples_final, &c.tolerance_missed})
        *v = in.get<std::uint64_t>();
    const std::uint64_t pass_values = in.get<std::uint64_t>();
    if (pass_values % 2 || pass_values > payload.size()) throw std::runtime_error(what + ": its final passes are not pairs");
    for (std::uint64_t k = 0; k < pass_values / 2; ++k) {
        const auto samples = in.get<std::uint64_t>();
        c.final_pass_queries[samples] += in.get<std::uint64_t>();
    }
    r.max_error_bound = in.get<double>();
    r.sampling_seconds = in.get<double>();
    r.seconds = in.get<double>();
    const std::size_t size = t.end - t.start;
    r.reference = in.get_vector<float>(size);
    r.std_error = in.get_vector<float>(size);
    r.weight = in.get_vector<float>(size);
    r.accounted = in.get_vector<std::uint8_t>(size);
    std::size_t compared = 0;
    for (std::uint8_t a : r.accounted) {
        if (a > 2) throw std::runtime_error(what + ": a pixel's comparison flag is " + std::to_string(a));
        compared += a != 0;
    }
    r.irradiance = in.get_vector<double>(compared);
    r.values = in.get_vector<double>(std::uint64_t(compared) * job.comparators.size());
    in.finish();
    if (c.pixel_lights != size) throw std::runtime_error(what + ": counts " + std::to_string(c.pixel_lights) + " pixels, not " + std::to_string(size));
    return r;
}

// The images and statistics, assembled from the tiles in item order (light by light, tile by tile):
// the sums of squares take the pixels in scan order as one process does, so the report's doubles are
// the same bits however the items were computed. Tiles that arrive early (an MPI rank, a resumed
// store) wait for the ones before them.
class SceneAssembly {
public:
    SceneAssembly(const SceneJob& job, SceneResult& result) : job_(job), result_(result) {}

    void accept(std::uint64_t id, TileResult tile) {
        if (id < next_ || !waiting_.emplace(id, std::move(tile)).second)
            throw std::logic_error("scene: item " + std::to_string(id) + " was assembled twice");
        for (auto it = waiting_.begin(); it != waiting_.end() && it->first == next_; it = waiting_.erase(it), ++next_) fold(next_, it->second);
    }
    // After the last item: the lights of an image without pixels (no items) get their empty images.
    void finish() {
        if (job_.tiles_per_light > 0) return;
        for (std::size_t l = 0; l < job_.d.lights.size(); ++l) {
            start_light(l);
            finish_light();
        }
    }

private:
    void start_light(std::size_t l) {
        const std::size_t n = job_.n, k = job_.comparators.size(), groups = job_.group_count;
        light_ = LightImages{};
        light_.light = job_.d.lights[l].name;
        light_.reference.assign(n, 0.0f);
        light_.std_error.assign(n, 0.0f);
        light_.weight.assign(n, 0.0f);
        light_.approximation.assign(k, std::vector<float>(n, 0.0f));
        light_.error.assign(k, std::vector<float>(n, 0.0f));
        light_.t = job_.bound_factor(job_.d.lights[l]);
        weighted_ = GroupedErrorStats(k, groups);
        term_ = GroupedErrorStats(k, groups);
        pixel_band_.assign(n, kUnlit);
        pixel_material_.assign(job_.d.has_material ? n : 0, 0);
    }

    // A tile's layers into the light's images and its compared pixels into the statistics (lit pixels only).
    void fold(std::uint64_t id, const TileResult& r) {
        const TileOf t = tile_of(job_, id);
        if (t.start == 0) start_light(t.light);
        add_counts(result_.counts, r.counts);
        result_.sampling_seconds += r.sampling_seconds;
        light_.seconds += r.seconds;
        light_.max_error_bound = std::max(light_.max_error_bound, r.max_error_bound);
        std::copy(r.reference.begin(), r.reference.end(), light_.reference.begin() + std::ptrdiff_t(t.start));
        std::copy(r.std_error.begin(), r.std_error.end(), light_.std_error.begin() + std::ptrdiff_t(t.start));
        std::copy(r.weight.begin(), r.weight.end(), light_.weight.begin() + std::ptrdiff_t(t.start));
        const std::size_t comparators = job_.comparators.size();
        std::size_t compared = 0;
        for (std::size_t i = t.start; i < t.end; ++i) {
            const std::uint8_t flag = r.accounted[i - t.start];
            if (!flag) continue;
            // data() + offset: with no comparator the values are empty, and &values[0] would bind a
            // reference to nothing (UBSan).
            account(i, flag == 2, r.irradiance[compared], r.values.data() + compared * comparators);
            ++compared;
        }
        if (t.end == job_.n) finish_light();
    }

    // Pixel i's approximations (values, one per comparator) against its reference: the layers and the
    // statistics (lit pixels only).
    void account(std::size_t i, bool lit, double irradiance, const double* values) {
        const PixelSurface p = job_.inputs.pixel(i);
        std::size_t groups[3] = {0, std::size_t(1 + band_of(p.roughness)), 0};
        std::size_t group_count = 2;
        if (job_.d.has_material) groups[group_count++] = job_.material_group.at(p.material);
        if (lit) {
            pixel_band_[i] = std::uint8_t(groups[1]);
            if (job_.d.has_material) pixel_material_[i] = std::uint32_t(groups[2]);
        }
        for (std::size_t k = 0; k < job_.comparators.size(); ++k) {
            const double diff = values[k] - double(light_.reference[i]);
            light_.approximation[k][i] = float(values[k]);
            light_.error[k][i] = float(diff * irradiance);
            if (!lit) continue;
            weighted_.add(k, groups, group_count, std::fabs(diff * irradiance));
            term_.add(k, groups, group_count, diff);
        }
    }

    // The light's statistics, their nearest-rank 99th percentiles from the error layers (|float(x)| =
    // float(|x|): the same values the statistics saw, in floats, so the accumulators keep no values).
    // Per comparator, the lit pixels' errors are bucketed by group (a counting sort: "all", the pixel's
    // band, its material) into one scratch vector, and each group's bucket gives its percentile by
    // nth_element: linear in pixels, whatever the number of groups.
    void finish_light() {
        const std::size_t n = job_.n, group_count = job_.group_count;
        const bool has_material = job_.d.has_material;
        std::vector<std::size_t> bucket_start(group_count + 1, 0);
        for (std::size_t i = 0; i < n; ++i) {
            if (pixel_band_[i] == kUnlit) continue;
            ++bucket_start[1];  // "all"
            ++bucket_start[std::size_t(pixel_band_[i]) + 1];
            if (has_material) ++bucket_start[std::size_t(pixel_material_[i]) + 1];
        }
        for (std::size_t g = 0; g < group_count; ++g) bucket_start[g + 1] += bucket_start[g];
        std::vector<float> scratch(bucket_start[group_count]);
        std::vector<std::size_t> fill(group_count);
        light_.stats.assign(job_.comparators.size(), std::vector<LitErrorSummary>(group_count));
        for (std::size_t k = 0; k < job_.comparators.size(); ++k) {
            std::copy(bucket_start.begin(), bucket_start.end() - 1, fill.begin());
            for (std::size_t i = 0; i < n; ++i) {
                if (pixel_band_[i] == kUnlit) continue;
                const float e = std::fabs(light_.error[k][i]);
                scratch[fill[0]++] = e;
                scratch[fill[pixel_band_[i]]++] = e;
                if (has_material) scratch[fill[pixel_material_[i]]++] = e;
            }
            for (std::size_t g = 0; g < group_count; ++g) {
                if (!weighted_.at(k, g).count()) continue;
                const auto first = scratch.begin() + std::ptrdiff_t(bucket_start[g]);
                const float p99 = nearest_rank(first, scratch.begin() + std::ptrdiff_t(bucket_start[g + 1]), 0.99);
                light_.stats[k][g] = LitErrorSummary::of(weighted_.at(k, g), term_.at(k, g), p99);
            }
        }
        result_.lights.push_back(std::move(light_));
        light_ = LightImages{};
        pixel_band_ = {};
        pixel_material_ = {};
    }

    const SceneJob& job_;
    SceneResult& result_;
    std::map<std::uint64_t, TileResult> waiting_;
    std::uint64_t next_ = 0;
    // The light being assembled.
    LightImages light_;
    // Per comparator and group: the weighted errors |diff| x N.L x intensity, and the unweighted diff.
    GroupedErrorStats weighted_, term_;
    std::vector<std::uint8_t> pixel_band_;      // per pixel: its roughness band's group (kUnlit: not lit)
    std::vector<std::uint32_t> pixel_material_;  // per pixel: its material's group
};

// Whether this process assembles and writes the outputs: one process, the merge, or MPI rank 0.
bool assembles(const schedule::ItemPlan* items) {
    return !items || ((!items->transport || items->transport->coordinator()) && items->shard.count == 1);
}

// A digest of 64-bit words (FNV-1a's multiply on whole words: eight times fewer steps than bytes, for
// the planes of a 4K image).
struct WordDigest {
    std::uint64_t h = kFnv1aOffset;
    void add(std::uint64_t v) { h = (h ^ v) * 1099511628211ULL; }
    void add(double v) {
        std::uint64_t bits;
        std::memcpy(&bits, &v, sizeof bits);
        add(bits);
    }
};


}  // namespace

std::uint64_t scene_work_items(const SceneInputs& inputs) {
    const std::size_t n = inputs.pixels(), tile = tile_size(inputs.description(), n);
    return std::uint64_t(inputs.description().lights.size()) * ((n + tile - 1) / tile);
}

schedule::CacheKey scene_cache_key(const SceneInputs& inputs, const SceneRunOptions& options, TermBackend& backend) {
    const SceneDescription& d = inputs.description();
    schedule::CacheKey key("scene");
    // The description as written (lights, sampling, comparators, where the images are), and what the
    // images hold: every pixel's surface as the job reads it.
    key.add_file("description", d.source);
    WordDigest pixels;
    for (std::size_t i = 0; i < inputs.pixels(); ++i) {
        const PixelSurface p = inputs.pixel(i);
        pixels.add(std::uint64_t(p.shaded) | std::uint64_t(p.anisotropic) << 1 | std::uint64_t(std::uint32_t(p.material)) << 32);
        for (const Vec3* v : {&p.normal, &p.tangent, &p.view, &p.position})
            for (double x : {v->x, v->y, v->z}) pixels.add(x);
        for (double x : {p.visibility, p.alpha_x, p.alpha_y, p.roughness}) pixels.add(x);
    }
    key.add("pixels", {inputs.width(), inputs.height(), hex16(pixels.h)});
    key.add("skip", options.skip)
        .add("tolerance", options.tolerance)
        .add("method_given", options.method_given)
        .add("method", to_string(options.method))
        .add("bake_seed_luts", options.bake_seed_luts);
    for (std::size_t i = 0; i < options.luts.size(); ++i) key.add_file("luts." + std::to_string(i), options.luts[i]);
    for (std::size_t i = 0; i < d.comparators.luts.size(); ++i)
        key.add_file("description.luts." + std::to_string(i), d.comparators.luts[i]);
    add_build(key, backend.config().build);
    add_results_place(key, backend.scheduler());
    return key;
}

const std::vector<std::string>& scene_cache_key_exclusions() {
    static const std::vector<std::string> excluded = {
        "progress, check_outputs: callbacks, told of the work, not part of it",
        "strict_domain: refuses a run before it computes, never changes an item",
        "memory_limit: refuses a run before it computes, never changes an item",
        "items: how the items are split and kept, not what they hold",
    };
    return excluded;
}

schedule::StoreKey scene_store_key(const SceneInputs& inputs, const SceneRunOptions& options, TermBackend& backend) {
    return scene_cache_key(inputs, options, backend).store_key(scene_work_items(inputs));
}

SceneResult run_scene(const SceneInputs& inputs, TermBackend& backend, const SceneRunOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    SceneJob job(inputs, backend, options);
    SceneResult result;
    result.width = inputs.width();
    result.height = inputs.height();
    result.backend = backend.name();
    resolve_method(job, result);
    make_comparators(job, result);
    tally_domains(job, result);
    mask_and_groups(job, result);

    // Work items: tiles of one light, sampling.tile_pixels pixels each, so the working memory (the key
    // table, the distinct queries, their estimates and the integrand's tallies) is bounded by the tile,
    // not the image. Deduplication finds repeats within a tile. Held for the whole run: the input planes
    // and the output layers; per light being assembled, one byte of roughness band and four of material
    // group per pixel (for the 99th percentiles, taken from the error layers at the end of the light).
    const bool writer = assembles(options.items);
    SceneAssembly assembly(job, result);
    schedule::ItemJob items;
    items.name = "scene";
    items.items = scene_work_items(inputs);
    items.compute = [&](std::uint64_t id) { return encode_tile(compute_tile(job, id)); };
    // A shard keeps its items in the store and assembles nothing; the writer assembles every item.
    items.accept = [&](std::uint64_t id, const std::string& payload) {
        if (writer) assembly.accept(id, decode_tile(job, id, payload));
    };
    // A stored item is trusted once it reads back whole as a tile of this job; else it is set aside.
    items.check = [&](std::uint64_t id, const std::string& payload) -> std::string {
        try {
            decode_tile(job, id, payload);
            return "";
        } catch (const std::exception& e) {
            return std::string("payload: ") + e.what();
        }
    };
    const schedule::ItemPlan one_process;
    const schedule::ItemPlan& plan = options.items ? *options.items : one_process;
    schedule::RunCallbacks callbacks;
    // Under MPI, rank 0 computes nothing: its progress is the items gathered.
    if (plan.transport) callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { job.progress("tiles", done, total); };
    const schedule::ItemRunReport report = schedule::run_item_job(items, plan, {backend.name()}, callbacks);
    result.loaded_items = report.loaded;
    result.computed_items = report.run.done;
    result.complete = writer && report.complete;
    if (!result.complete) {
        result.lights.clear();
        return result;
    }
    assembly.finish();
    result.seconds = seconds_since(start);
    return result;
}

json scene_report(const SceneResult& r) {
    json j;
    j["size"] = {r.width, r.height};
    j["tolerance"] = r.tolerance;
    j["method"] = to_string(r.method);
    if (r.area_tolerance > 0)
        j["area_lights"] = {{"area_tolerance", r.area_tolerance},
                            {"reference", r.method == Method::exact ? "T_area: the light sampled, the exact term at each direction (tolerance: its inner term's)"
                                                                    : "T_area: light directions and visible normals sampled jointly"},
                            {"comparators", "looked up at the light's centre; taps-exact: the tap rule with the exact point term"}};
    if (r.method == Method::exact) {
        SamplingPlan p;
        p.method = Method::exact;
        p.tolerance = r.tolerance;
        j["exact"] = exact_provenance(p);
    }
    j["backend"] = json_safe(r.backend);
    const SkipCounts& c = r.counts;
    // What sampling every pixel-light that has a query would have cost at the measured time per sampled
    // query (an extrapolation; `--no-skip` measures the baseline that the integrand's exact cases allow).
    const double every = c.sampled ? r.sampling_seconds * double(c.pixel_lights - c.masked - c.view_below_horizon) / double(c.sampled) : 0;
    j["seconds"] = {{"total", r.seconds}, {"lut_bakes", r.lut_seconds}, {"sampling", r.sampling_seconds},
                    {"sampling_every_pixel_extrapolated", every}};
    j["work"] = {{"pixel_lights", c.pixel_lights}, {"masked", c.masked}, {"view_below_horizon", c.view_below_horizon},
                 {"light_below_horizon", c.light_below_horizon}, {"zero_region", c.zero_region}, {"v_one", c.v_one},
                 {"duplicates", c.duplicates}, {"sampled", c.sampled}, {"skipped_fraction", c.skipped_fraction()},
                 {"samples_drawn", c.samples_drawn}, {"samples_final", c.samples_final}, {"tolerance_missed", c.tolerance_missed}};
    json passes = json::object();
    for (const auto& [samples, queries] : c.final_pass_queries) passes[std::to_string(samples)] = queries;
    j["work"]["final_pass_queries"] = passes;
    j["comparators"] = r.comparators;
    // Lit pixel-lights outside each comparator's domain, over every light.
    for (std::size_t k = 0; k < r.comparators.size() && k < r.outside_domain.size(); ++k)
        j["comparator_domains"][r.comparators[k]] = compare::domain_report(r.domains[k], r.outside_domain[k]);
    j["groups"] = r.groups;
    j["error_schema"] = kErrorSummarySchema;
    j["error_weighting"] = kLitErrorWeighting;
    for (const auto& l : r.lights) {
        json lj;
        lj["name"] = l.light;
        lj["max_error_bound"] = l.max_error_bound;
        lj["seconds"] = l.seconds;
        for (std::size_t k = 0; k < r.comparators.size(); ++k)
            for (std::size_t g = 0; g < r.groups.size(); ++g) {
                lj["errors"][r.comparators[k]][r.groups[g]] = l.stats[k][g];
            }
        j["lights"].push_back(lj);
    }
    return j;
}

namespace {

std::string markdown(const SceneResult& r) {
    std::ostringstream m;
    const SkipCounts& c = r.counts;
    m << "# microshadow scene report\n\n";
    m << r.width << " x " << r.height << " pixels, " << r.lights.size() << " light(s), tolerance " << format_g(r.tolerance)
      << " (99.9 % bound per pixel), " << format_g(r.seconds) << " s on " << r.backend << " (LUT bakes " << format_g(r.lut_seconds)
      << " s, sampling " << format_g(r.sampling_seconds) << " s; sampling every unmasked pixel-light would take about "
      << format_g(c.sampled ? r.sampling_seconds * double(c.pixel_lights - c.masked - c.view_below_horizon) / double(c.sampled) : 0)
      << " s at the same time per query).\n\n";
    m << "| pixel x light | masked | view below horizon | light below horizon | zero region | v = 1 | duplicates | sampled | skipped |\n"
      << "|---|---|---|---|---|---|---|---|---|\n"
      << "| " << c.pixel_lights << " | " << c.masked << " | " << c.view_below_horizon << " | " << c.light_below_horizon << " | "
      << c.zero_region << " | " << c.v_one << " | " << c.duplicates << " | " << c.sampled << " | "
      << format_g(100 * c.skipped_fraction()) << " % |\n\n";
    bool any_domain = false;
    for (const auto& dm : r.domains) any_domain = any_domain || dm.has_value();
    if (any_domain) {
        m << "Lit pixel-lights outside each comparator's domain (its metadata's roughness, visibility and NdotV ranges; "
             "answered there by clamping, so its errors below include them):\n\n| comparator | domain | outside | lookups |\n|---|---|---|---|\n";
        for (std::size_t k = 0; k < r.comparators.size() && k < r.domains.size(); ++k)
            if (r.domains[k])
                m << "| " << r.comparators[k] << " | " << r.domains[k]->describe() << " | " << r.outside_domain[k].outside << " | "
                  << r.outside_domain[k].lookups << " |\n";
        m << "\n";
    }
    for (const auto& l : r.lights) {
        m << "## light `" << l.light << "`\n\nReference: max error bound " << format_g(l.max_error_bound)
          << ". Errors weighted as shading sees them (|approximation - reference| x max(N.L, 0) x intensity), over lit pixels;"
          << " the `term` columns are of |approximation - reference| unweighted.\n\n";
        m << "| comparator | lit max | lit RMS | lit p99 | term max | term RMS |";
        for (std::size_t g = 1; g < r.groups.size(); ++g) m << " lit RMS " << r.groups[g] << " |";
        m << "\n|---|---|---|---|---|---|";
        for (std::size_t g = 1; g < r.groups.size(); ++g) m << "---|";
        m << "\n";
        for (std::size_t k = 0; k < r.comparators.size(); ++k) {
            const LitErrorSummary& s = l.stats[k][0];
            m << "| " << r.comparators[k] << " | " << format_g(s.lit_max_abs) << " | " << format_g(s.lit_rms) << " | "
              << format_g(s.lit_p99) << " | " << format_g(s.term_max_abs) << " | " << format_g(s.term_rms) << " |";
            for (std::size_t g = 1; g < r.groups.size(); ++g)
                m << " " << (l.stats[k][g].count ? format_g(l.stats[k][g].lit_rms) : std::string("-")) << " |";
            m << "\n";
        }
        m << "\n";
    }
    return m.str();
}

}  // namespace

namespace {
void write_scene_files(const SceneResult& r, const std::string& dir, const json& provenance);
}  // namespace

std::vector<std::string> scene_output_files(const std::vector<std::string>& lights, const std::vector<std::string>& comparators) {
    std::vector<std::string> files{"scene.exr", "report.json", "report.md"};
    for (const auto& l : lights) {
        files.push_back(l + "_reference.png");
        if (!comparators.empty()) files.push_back(l + "_errors.png");
        for (const auto& c : comparators) files.push_back(l + "_" + c + ".png");
    }
    return files;
}

std::vector<std::string> scene_exr_layers(const std::vector<std::string>& lights, const std::vector<std::string>& comparators) {
    std::vector<std::string> layers{"mask"};
    for (const auto& l : lights) {
        for (const char* plane : {".reference", ".std_error", ".weight"}) layers.push_back(l + plane);
        for (const auto& c : comparators) {
            layers.push_back(l + "." + c);
            layers.push_back(l + "." + c + "_error");
        }
    }
    return layers;
}

void check_output_folder(const std::string& dir) {
    std::error_code ec;
    fs::path p = dir.empty() ? fs::path(".") : fs::path(dir);
    if (fs::exists(p, ec)) {
        if (!fs::is_directory(p, ec)) throw OutputError(dir + ": exists and is not a folder (it names the output folder)");
        if (!platform::can_create_in(p.string()))
            throw OutputError(dir + ": cannot write in this folder (" + std::strerror(errno) + ")");
        return;
    }
    // Missing: the nearest folder above it that exists must let us create it.
    fs::path above = fs::absolute(p, ec).parent_path();
    while (!above.empty() && !fs::exists(above, ec) && above != above.parent_path()) above = above.parent_path();
    if (!fs::is_directory(above, ec))
        throw OutputError(dir + ": cannot be created (" + above.string() + " is not a folder)");
    if (!platform::can_create_in(above.string()))
        throw OutputError(dir + ": cannot be created (" + above.string() + ": " + std::strerror(errno) + ")");
}

void check_scene_outputs(const std::string& dir, const std::vector<std::string>& lights, const std::vector<std::string>& comparators) {
    std::set<std::string> seen;
    for (const auto& f : scene_output_files(lights, comparators))
        if (!seen.insert(f).second)
            throw OutputError(dir + ": two outputs would both be " + f + " (a light's name and a comparator's meet in one file name): rename "
                              "the light or the LUT file");
    seen.clear();
    for (const auto& l : scene_exr_layers(lights, comparators))
        if (!seen.insert(l).second) throw OutputError(dir + "/scene.exr: two layers would both be named " + l + ": rename the light or the LUT file");
    check_output_folder(dir);
    std::error_code ec;
    if (fs::is_directory(dir, ec))
        for (const auto& f : scene_output_files(lights, comparators)) check_writable_destination((fs::path(dir) / f).string());
    else
        for (const auto& f : scene_output_files(lights, comparators))
            if (f.size() + 16 > 255) throw OutputError(dir + "/" + f + ": the file name is too long");
}

namespace {

// The outputs of the run that last wrote DIR, from its report.json (empty when there is none or it
// cannot be read: then nothing is removed).
std::vector<std::string> previous_outputs(const std::string& dir) {
    std::ifstream in(fs::path(dir) / "report.json");
    if (!in) return {};
    try {
        const json j = json::parse(in);
        std::vector<std::string> lights, comparators;
        for (const auto& l : j.at("lights")) lights.push_back(l.at("name").get<std::string>());
        for (const auto& c : j.at("comparators")) comparators.push_back(c.get<std::string>());
        // Only plain names inside DIR (the report may have been edited): never a path elsewhere.
        std::vector<std::string> files;
        for (const auto& f : scene_output_files(lights, comparators))
            if (!f.empty() && f[0] != '.' && f.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.") == std::string::npos)
                files.push_back(f);
        return files;
    } catch (const std::exception&) {
        return {};
    }
}

}  // namespace

void write_scene_outputs(const SceneResult& r, const std::string& dir, const json& provenance) {
    std::vector<std::string> lights;
    for (const auto& l : r.lights) lights.push_back(l.light);
    check_scene_outputs(dir, lights, r.comparators);
    const std::vector<std::string> before = previous_outputs(dir);
    std::error_code ec;
    const bool created = !fs::exists(dir, ec);
    fs::create_directories(dir, ec);
    if (ec) throw std::invalid_argument(dir + ": cannot create the output folder (" + ec.message() + ")");
    try {
        write_scene_files(r, dir, provenance);
    } catch (...) {
        if (created) fs::remove(dir, ec);  // only if still empty: never a file of ours or anyone's
        throw;
    }
    // The new set is in place: a previous run's files that it does not hold are stale.
    const std::vector<std::string> now = scene_output_files(lights, r.comparators);
    for (const auto& f : before)
        if (std::find(now.begin(), now.end(), f) == now.end() && fs::is_regular_file(fs::path(dir) / f, ec))
            fs::remove(fs::path(dir) / f, ec);
}

namespace {

void write_scene_files(const SceneResult& r, const std::string& dir, const json& provenance) {
    OutputSet out;
    const auto path = [&](const std::string& name) { return (fs::path(dir) / name).string(); };
    const std::size_t exr = out.add(path("scene.exr"), true);
    const std::size_t report_json = out.add(path("report.json"));
    const std::size_t report_md = out.add(path("report.md"));
    json report = scene_report(r);
    report["provenance"] = provenance;

    std::vector<ExrLayer> layers{{"mask", r.mask.data()}};
    std::vector<std::vector<float>> bounds;
    bounds.reserve(r.lights.size());
    for (const auto& l : r.lights) {
        layers.push_back({l.light + ".reference", l.reference.data()});
        layers.push_back({l.light + ".std_error", l.std_error.data()});
        layers.push_back({l.light + ".weight", l.weight.data()});
        for (std::size_t k = 0; k < r.comparators.size(); ++k) {
            layers.push_back({l.light + "." + r.comparators[k], l.approximation[k].data()});
            layers.push_back({l.light + "." + r.comparators[k] + "_error", l.error[k].data()});
        }
    }
    write_exr(out.temp_path(exr), r.width, r.height, layers, {{"microshadow", dump_json(report)}});

    const std::string weighted = "ERROR X N.L X I";
    for (const auto& l : r.lights) {
        // Reference and its error bound.
        std::vector<float> bound(l.std_error.size());
        for (std::size_t i = 0; i < bound.size(); ++i) bound[i] = float(l.t * l.std_error[i]);
        const std::size_t ref_png = out.add(path(l.light + "_reference.png"), true);
        write_png_rgb(out.temp_path(ref_png),
                      render_panels(r.width, r.height,
                                    {{"REFERENCE TERM", l.reference.data(), false, 0, 1, 1},
                                     {"ERROR BOUND, 99.9 PER CENT", bound.data(), false, 0, r.tolerance, 1}},
                                    r.mask.data(), {"LIGHT " + to_upper(l.light) + ": THE GENERIC TERM BY VNDF SAMPLING"}));
        // Every comparator's weighted error on one shared scale.
        double shared = 0;
        for (std::size_t k = 0; k < r.comparators.size(); ++k) shared = std::max(shared, l.stats[k][0].lit_max_abs);
        std::vector<Panel> all;
        for (std::size_t k = 0; k < r.comparators.size(); ++k)
            all.push_back({to_upper(r.comparators[k]), l.error[k].data(), true, 0, 1, shared > 0 ? shared : 1});
        if (!all.empty()) {
            const std::size_t errors_png = out.add(path(l.light + "_errors.png"), true);
            write_png_rgb(out.temp_path(errors_png),
                          render_panels(r.width, r.height, all, r.mask.data(),
                                        {"LIGHT " + to_upper(l.light) + ": (APPROXIMATION - REFERENCE) X N.L X INTENSITY, ONE SCALE"}, 160));
        }
        for (std::size_t k = 0; k < r.comparators.size(); ++k) {
            const LitErrorSummary& s = l.stats[k][0];
            const std::size_t png = out.add(path(l.light + "_" + r.comparators[k] + ".png"), true);
            write_png_rgb(out.temp_path(png),
                          render_panels(r.width, r.height,
                                        {{"REFERENCE", l.reference.data(), false, 0, 1, 1},
                                         {to_upper(r.comparators[k]), l.approximation[k].data(), false, 0, 1, 1},
                                         {weighted, l.error[k].data(), true, 0, 1, s.lit_max_abs > 0 ? s.lit_max_abs : 1}},
                                        r.mask.data(),
                                        {"LIGHT " + to_upper(l.light) + ": " + to_upper(r.comparators[k]) + " AGAINST THE REFERENCE",
                                         "WEIGHTED ERROR MAX " + format_g(s.lit_max_abs) + "  RMS " + format_g(s.lit_rms) + "  P99 " + format_g(s.lit_p99)}));
        }
    }
    out.stream(report_json) << dump_json(report, 2) << "\n";
    out.stream(report_md) << markdown(r);
    out.commit();
}

}  // namespace

}  // namespace ms::scene
