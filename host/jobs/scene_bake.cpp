// `microshadow bake --scene`: the scene's domain decides the bake (the plan is in scene_bake.hpp).
#include "jobs/scene_bake.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/text.hpp"
#include "jobs/eval.hpp"
#include "jobs/scene.hpp"
#include "lut/exr_lut.hpp"
#include "lut/formats/lut_formats.hpp"
#include "lut/lookup.hpp"
#include "scene/histogram_plot.hpp"
#include "scene/image_io.hpp"

namespace ms::scene {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The histograms in file order, with what each counts.
struct HistogramKind {
    const char* name;
    const char* unit;
    const char* label;  // for the bitmap font of the plots (capitals, digits, a little punctuation)
    double min, max;
    double SceneLookup::*field;
};
const HistogramKind kHistograms[5] = {
    {"visibility", "AO fraction", "VISIBILITY (AO FRACTION)", 0, 1, &SceneLookup::visibility},
    {"roughness", "perceptual, (alpha_x alpha_y)^(1/4)", "ROUGHNESS (PERCEPTUAL, SQRT OF ALPHA)", 0, 1, &SceneLookup::roughness},
    {"n_dot_v", "cosine", "NDOTV (COSINE)", 0, 1, &SceneLookup::n_dot_v},
    {"n_dot_l", "cosine", "NDOTL (COSINE)", 0, 1, &SceneLookup::n_dot_l},
    {"azimuth", "degrees", "RELATIVE AZIMUTH OF V AND L (DEGREES)", 0, 180, &SceneLookup::azimuth_degrees},
};

// The two taps of a lookup on an axis, as lookup.cpp takes them (clamp-to-edge, i1 = i0 + 1 at most).
std::pair<std::uint32_t, std::uint32_t> taps(const Axis& a, double p) {
    if (a.count <= 1 || a.max == a.min) return {0, 0};
    const auto i0 = std::uint32_t(std::floor(a.texel_coordinate(p)));
    return {i0, std::min(i0 + 1, a.count - 1)};
}

// The channels a lookup at roughness r blends, as lookup.cpp chooses them (roughness ascending).
std::pair<std::uint32_t, std::uint32_t> channel_taps(const std::vector<double>& sorted, double r) {
    if (sorted.size() == 1 || r <= sorted.front()) return {0, 0};
    if (r >= sorted.back()) return {std::uint32_t(sorted.size() - 1), std::uint32_t(sorted.size() - 1)};
    std::uint32_t k = 1;
    while (sorted[k] < r) ++k;
    return {k - 1, k};
}

// An axis fitted to data in [lo, hi]: endpoints over the range, or one texel for constant data.
Axis fitted_axis(const Axis& base, double lo, double hi) {
    Axis a = base;
    a.texel = TexelConvention::endpoints;
    a.min = lo;
    a.max = hi;
    if (!(hi > lo)) a.count = 1, a.max = lo;
    return a;
}

std::string file_name(const std::string& light) {
    std::string s = light;
    for (char& c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) c = '_';
    return s;
}

// A CSV field in quotes (a light's name may hold a comma).
std::string csv_field(const std::string& s) {
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

}  // namespace

std::uint64_t Histogram::total() const {
    std::uint64_t t = 0;
    for (auto c : counts) t += c;
    return t;
}

std::vector<LightDomain> scene_domain(const SceneInputs& inputs, std::uint32_t bins) {
    const SceneDescription& d = inputs.description();
    std::vector<LightDomain> out;
    for (const Light& light : d.lights) {
        // The domain is the point lookups a renderer makes; an area light's (one at its centre, or taps)
        // are no single direction with an irradiance weight, which the comparison below needs.
        if (light.is_area())
            throw SceneError(d.source + ": light '" + light.name + "' is a " + to_string(light.type) +
                             " light: bake --scene takes directional and point lights (run `microshadow scene` for area lights)");
        LightDomain ld;
        ld.light = light.name;
        for (std::size_t i = 0; i < inputs.pixels(); ++i) {
            const PixelSurface p = inputs.pixel(i);
            const LightQuery q = light_query(p, light);
            if (q.status == PixelStatus::masked || q.status == PixelStatus::view_below_horizon) continue;
            ++ld.shaded;
            if (q.status != PixelStatus::shaded) continue;  // light at or below the horizon: nothing to look up
            SceneLookup l;
            l.pixel = std::uint32_t(i);
            l.visibility = p.visibility;
            // As the scene job looks LUTs up (jobs/scene.cpp comparator_value).
            l.n_dot_l = std::clamp(q.n_dot_l, 0.0, 1.0);
            l.n_dot_v = std::clamp(q.n_dot_v, 0.0, 1.0);
            l.roughness = p.roughness;
            l.azimuth_degrees = q.azimuth * 180.0 / 3.14159265358979323846;
            l.weight = q.irradiance;
            ld.lookups.push_back(l);
        }
        for (const HistogramKind& k : kHistograms) {
            Histogram h;
            h.name = k.name;
            h.unit = k.unit;
            h.min = k.min;
            h.max = k.max;
            h.counts.assign(bins, 0);
            h.data_min = ld.lookups.empty() ? 0 : 1e300;
            h.data_max = ld.lookups.empty() ? 0 : -1e300;
            for (const SceneLookup& l : ld.lookups) {
                const double v = l.*k.field;
                h.data_min = std::min(h.data_min, v);
                h.data_max = std::max(h.data_max, v);
                const double t = (v - k.min) / (k.max - k.min) * bins;
                ++h.counts[std::size_t(std::clamp(t, 0.0, double(bins - 1)))];
            }
            ld.histograms.push_back(std::move(h));
        }
        out.push_back(std::move(ld));
    }
    return out;
}

SceneBakePlan plan_scene_bake(const std::vector<LightDomain>& domain, const BakeSpec& base, bool fit) {
    std::size_t lookups = 0;
    double lo[4] = {1e300, 1e300, 1e300, 1e300}, hi[4] = {-1e300, -1e300, -1e300, -1e300};  // v, NdotL, NdotV, r
    std::set<double> roughness;
    for (const auto& ld : domain)
        for (const SceneLookup& l : ld.lookups) {
            ++lookups;
            const double x[4] = {l.visibility, l.n_dot_l, l.n_dot_v, l.roughness};
            for (int k = 0; k < 4; ++k) lo[k] = std::min(lo[k], x[k]), hi[k] = std::max(hi[k], x[k]);
            if (roughness.size() <= 4) roughness.insert(l.roughness);
        }
    if (!lookups) throw std::invalid_argument("the scene has no lit, shaded pixel: nothing to bake for it");

    SceneBakePlan plan;
    plan.fitted = fit;
    for (int k = 0; k < 4; ++k) plan.domain_min[k] = lo[k], plan.domain_max[k] = hi[k];
    BakeSpec& s = plan.spec;
    s = base;
    if (fit) {
        s.layout = LutLayout::custom;
        // Visibility must span a range (validate); constant AO gets the smallest range around it.
        double vlo = lo[0], vhi = hi[0];
        if (!(vhi > vlo)) vlo = std::max(0.0, vlo - 1e-3), vhi = std::min(1.0, vhi + 1e-3);
        s.visibility = fitted_axis(base.visibility, vlo, vhi);
        s.visibility.count = std::max(2u, base.visibility.count);
        s.n_dot_l = fitted_axis(base.n_dot_l, lo[1], hi[1]);
        s.n_dot_v = fitted_axis(base.n_dot_v, lo[2], hi[2]);
        // Roughness: the values themselves when there are at most 4 (roughness 0 is clamped to alpha
        // 1e-3 by the scene, r = alpha^(1/2) > 0), else 4 channels evenly over the data's range.
        s.roughness.clear();
        if (roughness.size() <= 4) {
            for (double r : roughness) s.roughness.push_back(std::clamp(r, 1e-3, 1.0));
        } else {
            for (int c = 0; c < 4; ++c) s.roughness.push_back(std::clamp(lo[3] + (hi[3] - lo[3]) * c / 3.0, 1e-3, 1.0));
        }
    }
    validate(s);
    // Channel indices in ascending roughness (the lookup's order).
    const std::uint32_t nc = std::uint32_t(s.roughness.size()), nl = s.n_dot_l.count, nvv = s.n_dot_v.count, nv = s.visibility.count;
    std::vector<std::uint32_t> order(nc);
    for (std::uint32_t c = 0; c < nc; ++c) order[c] = c;
    std::sort(order.begin(), order.end(), [&](auto a, auto b) { return s.roughness[a] < s.roughness[b]; });
    std::vector<double> sorted(nc);
    for (std::uint32_t c = 0; c < nc; ++c) sorted[c] = s.roughness[order[c]];

    // Every lookup's footprint: rows (the baked unit) and texels (what is reported as touched).
    std::vector<std::uint8_t> rows(std::size_t(nc) * nvv * nl, 0);
    std::vector<std::uint8_t> texels(std::size_t(nc) * nvv * nl * nv, 0);
    std::vector<std::uint8_t> channel_used(nc, 0);
    for (const auto& ld : domain)
        for (const SceneLookup& l : ld.lookups) {
            const auto [c0, c1] = channel_taps(sorted, l.roughness);
            const auto [z0, z1] = taps(s.n_dot_v, l.n_dot_v);
            const auto [l0, l1] = taps(s.n_dot_l, l.n_dot_l);
            const auto [v0, v1] = taps(s.visibility, l.visibility);
            for (std::uint32_t c : {order[c0], order[c1]}) {
                channel_used[c] = 1;
                for (std::uint32_t z : {z0, z1})
                    for (std::uint32_t r : {l0, l1}) {
                        const std::size_t row = (std::size_t(z) * nc + c) * nl + r;
                        rows[row] = 1;
                        texels[row * nv + v0] = texels[row * nv + v1] = 1;
                    }
            }
        }
    plan.rows = rows.size();
    plan.texels = texels.size();
    plan.slices = std::uint64_t(nc) * nvv;
    for (auto r : rows) plan.baked_rows += r;
    for (auto t : texels) plan.touched_texels += t;
    plan.baked_texels = plan.baked_rows * nv;
    for (std::uint64_t slice = 0; slice < plan.slices; ++slice)
        plan.baked_slices += std::any_of(rows.begin() + std::ptrdiff_t(slice * nl), rows.begin() + std::ptrdiff_t((slice + 1) * nl),
                                         [](std::uint8_t r) { return r != 0; });
    for (std::uint32_t c = 0; c < nc; ++c)
        if (channel_used[c]) plan.channels_touched.push_back(c);
    // Every row touched: a full bake, no coverage record.
    if (plan.baked_rows < plan.rows) s.baked_rows = std::move(rows);
    return plan;
}

json coverage_record(const SceneBakePlan& plan) {
    const BakeSpec& s = plan.spec;
    const std::uint32_t nc = std::uint32_t(s.roughness.size()), nl = s.n_dot_l.count;
    json runs = json::array();
    for (std::uint32_t z = 0; z < s.n_dot_v.count; ++z)
        for (std::uint32_t c = 0; c < nc; ++c)
            for (std::uint32_t r = 0; r < nl;) {
                if (!s.row_baked(std::uint64_t(z) * nc + c, r)) {
                    ++r;
                    continue;
                }
                std::uint32_t end = r;
                while (end < nl && s.row_baked(std::uint64_t(z) * nc + c, end)) ++end;
                runs.push_back({c, z, r, end});
                r = end;
            }
    return {{"unbaked", "NaN"},
            {"what", "a partial bake (microshadow bake --scene): only the rows listed, [channel, n_dot_v index, first n_dot_l "
                     "row, end row), are baked; every other texel is NaN and a lookup touching one is refused"},
            {"baked_rows", plan.baked_rows},
            {"rows", runs},
            {"total_rows", plan.rows},
            {"baked_texels", plan.baked_texels},
            {"texels", plan.texels},
            {"touched_texels", plan.touched_texels}};
}

json scene_lut_metadata(const SceneBakePlan& plan, const BakeResult& bake) {
    json meta = bake_metadata(plan.spec, bake);
    if (!plan.spec.baked_rows.empty()) meta["coverage"] = coverage_record(plan);
    if (plan.fitted) {
        json domain = {{"what", "a LUT fitted to one scene (microshadow bake --scene, --scene-layout fit): its axes span that scene's "
                                "lookups only, and a lookup outside these ranges is refused, not clamped"}};
        const char* names[4] = {"visibility", "n_dot_l", "n_dot_v", "roughness"};
        for (int k = 0; k < 4; ++k) domain[names[k]] = {plan.domain_min[k], plan.domain_max[k]};
        domain["outside"] = "refused";
        meta["domain"] = domain;
    }
    return meta;
}

schedule::StoreKey scene_bake_store_key(const SceneBakePlan& plan, const schedule::Scheduler& scheduler) {
    schedule::StoreKey key = bake_store_key(plan.spec, scheduler);
    key.job = "scene-bake";
    return key;
}

SceneBakeResult run_scene_bake(const SceneInputs& inputs, const std::vector<LightDomain>& domain, const BakeSpec& base,
                               TermBackend& backend, const SceneBakeOptions& options) {
    const SceneDescription& d = inputs.description();
    SceneBakeResult r;
    r.plan = plan_scene_bake(domain, base, options.fit);
    r.channels = bake_channels(r.plan.spec);
    r.serve_error = options.serve_error;
    auto progress = [&](const std::string& phase) {
        BakeCallbacks cb;
        if (options.progress) cb.progress = [&options, phase](std::size_t done, std::size_t total) { options.progress(phase, done, total); };
        return cb;
    };
    // Only the process that writes (one process, the merge, MPI rank 0) compares, so only it warms up.
    const schedule::ItemPlan* items = options.items;
    const bool writer = !items || ((!items->transport || items->transport->coordinator()) && items->shard.count == 1);
    if (options.compare && writer) {
        // Warm-up: the first bake on a scheduler builds the kernels (PoCL: seconds), which would be
        // charged to whichever timed bake ran first. One row of one slice builds them.
        BakeSpec warm = r.plan.spec;
        warm.baked_rows.clear();
        warm.roughness.resize(1);
        warm.n_dot_v.count = warm.n_dot_l.count = 1;
        warm.tolerance = 0;  // one batch of the spec's samples: their point set is then cached for both bakes
        bake_lut(warm, backend.scheduler());
    }
    r.bake = bake_lut(r.plan.spec, backend.scheduler(), progress("scene bake"), options.items ? *options.items : schedule::ItemPlan{});
    // A shard, or a rank that only computed: the comparison is the writer's.
    if (!options.compare || !r.bake.complete) return r;

    // The same layout in full (same scheduler, same run): what skipping saves.
    BakeSpec full = r.plan.spec;
    if (full.baked_rows.empty()) {
        r.full_seconds = r.bake.seconds;  // every row was touched: the scene bake is the full bake
        r.full_histogram_updates = r.bake.sample_node_rows;
        r.full_batches = r.bake.batches;
    } else {
        full.baked_rows.clear();
        const BakeResult f = bake_lut(full, backend.scheduler(), progress("full bake (for the time ratio)"));
        r.full_seconds = f.seconds;
        r.full_histogram_updates = f.sample_node_rows;
        r.full_batches = f.batches;
    }
    // The default LUT: seed-3d at the base's counts and sampling.
    BakeSpec standard = default_bake_spec(LutLayout::seed_3d, base.n_dot_l.count);
    standard.term = base.term;
    standard.sequence = base.sequence, standard.replicates = base.replicates, standard.samples = base.samples;
    standard.seed = base.seed, standard.tolerance = base.tolerance, standard.max_batches = base.max_batches;
    standard.build = base.build;
    standard.visibility.count = base.visibility.count;
    standard.n_dot_v.count = base.n_dot_v.count;
    r.default_size = base.n_dot_l.count;
    const BakeResult standard_bake = bake_lut(standard, backend.scheduler(), progress("default LUT"));
    r.default_seconds = standard_bake.seconds;
    const LutLookup default_lut(bake_lut_file(standard, standard_bake, bake_metadata(standard, standard_bake)));
    const json meta = scene_lut_metadata(r.plan, r.bake);
    const LutLookup scene_lut(lutfmt::make_lut_file({r.plan.spec.visibility, r.plan.spec.n_dot_l, r.plan.spec.n_dot_v},
                                                           r.channels, r.bake.value, meta));

    // The reference on an evenly strided sample of each light's lookups (deterministic).
    const auto ref_start = Clock::now();
    SamplingPlan plan;
    plan.samples = options.reference_samples;
    plan.replicates = d.sampling.replicates;
    plan.seed = d.sampling.seed;
    // The scene's method decides the reference too; the exact one's std_error is its estimate itself.
    plan.method = d.sampling.method;
    if (plan.method == Method::exact) plan.tolerance = d.sampling.tolerance;
    const double t = plan.method == Method::exact ? 1.0 : student_t_999(plan.replicates);
    TermOptions term;
    term.form = d.sampling.form;
    term.ao_weighting = d.ao_weighting;
    r.default_serves = true;
    for (std::size_t li = 0; li < domain.size(); ++li) {
        const LightDomain& ld = domain[li];
        const std::size_t n = std::min<std::size_t>(ld.lookups.size(), options.error_lookups);
        std::vector<const SceneLookup*> chosen;
        std::vector<Query> queries;
        for (std::size_t k = 0; k < n; ++k) {
            const SceneLookup& l = ld.lookups[k * ld.lookups.size() / n];
            chosen.push_back(&l);
            queries.push_back(light_query(inputs.pixel(l.pixel), d.lights[li]).query);
        }
        const auto est = evaluate(backend, queries, term, plan, nullptr, [&](std::size_t done, std::size_t total) {
            if (options.progress) options.progress("reference (" + ld.light + ")", done, total);
        });
        SceneBakeResult::LightErrors e;
        e.light = ld.light;
        // The weighted errors keep their values for the 99th percentile.
        ErrorStats ws(ErrorStats::Keep::values), ts, wd(ErrorStats::Keep::values), td;
        for (std::size_t k = 0; k < chosen.size(); ++k) {
            const SceneLookup& l = *chosen[k];
            const double ref = est[k].term;
            e.reference_bound = std::max(e.reference_bound, t * est[k].std_error);
            const double a = scene_lut(l.visibility, l.n_dot_l, l.n_dot_v, l.roughness) - ref;
            const double b = default_lut(l.visibility, l.n_dot_l, l.n_dot_v, l.roughness) - ref;
            ts.add(a);
            ws.add(std::fabs(a) * l.weight);
            td.add(b);
            wd.add(std::fabs(b) * l.weight);
        }
        e.scene_lut = LitErrorSummary::of(ws, ts, ws.nearest_rank(0.99));
        e.default_lut = LitErrorSummary::of(wd, td, wd.nearest_rank(0.99));
        if (options.azimuth_floor_samples) {
            // The term of each isotropic sampled lookup at the trapezoid nodes of the azimuth (wi = (sin_v,
            // 0, cos_v) in the pixel's frame, inputs.hpp; wo turned about the normal), and its mean.
            SamplingPlan floor_plan = plan;
            floor_plan.samples = options.azimuth_floor_samples;
            std::vector<Query> nodes;
            std::vector<std::size_t> which;  // index into chosen
            for (std::size_t k = 0; k < chosen.size(); ++k) {
                const Query& q = queries[k];
                if (q.alpha_x != q.alpha_y) continue;  // anisotropic: the frame's azimuth matters
                const double sl = std::sqrt(std::max(0.0, 1 - q.wo.z * q.wo.z));
                for (std::uint32_t i = 0; i < kAzimuthFloorNodes; ++i) {
                    const double phi = 3.14159265358979323846 * i / (kAzimuthFloorNodes - 1);
                    Query n = q;
                    n.wo = {sl * std::cos(phi), sl * std::sin(phi), q.wo.z};
                    nodes.push_back(n);
                }
                which.push_back(k);
            }
            const auto node_est = evaluate(backend, nodes, term, floor_plan, nullptr, [&](std::size_t done, std::size_t total) {
                if (options.progress) options.progress("azimuth mean (" + ld.light + ")", done, total);
            });
            ErrorStats wf(ErrorStats::Keep::values), tf;
            for (std::size_t m = 0; m < which.size(); ++m) {
                // Every node uses the same points, so their errors are correlated: the mean's standard error
                // is bounded by the weighted sum of theirs (the triangle inequality), not the root of squares.
                double mean = 0, std_error = 0;
                for (std::uint32_t i = 0; i < kAzimuthFloorNodes; ++i) {
                    const double w = (i == 0 || i + 1 == kAzimuthFloorNodes ? 0.5 : 1.0) / (kAzimuthFloorNodes - 1);
                    const Estimate& ne = node_est[m * kAzimuthFloorNodes + i];
                    mean += w * ne.term;
                    std_error += w * ne.std_error;
                }
                e.azimuth_floor_bound = std::max(e.azimuth_floor_bound, t * std_error);
                const SceneLookup& l = *chosen[which[m]];
                const double d = std::fabs(mean - est[which[m]].term);
                tf.add(d);
                wf.add(d * l.weight);
            }
            e.azimuth_floor = LitErrorSummary::of(wf, tf, wf.nearest_rank(0.99));
        }
        if (e.default_lut.lit_max_abs + e.reference_bound > options.serve_error) r.default_serves = false;
        r.errors.push_back(e);
    }
    r.reference_seconds = since(ref_start);
    return r;
}

json scene_bake_report(const SceneBakeResult& r, const std::vector<LightDomain>& domain) {
    const SceneBakePlan& p = r.plan;
    json j;
    json axes = json::array();
    for (const Axis* a : {&p.spec.visibility, &p.spec.n_dot_l, &p.spec.n_dot_v})
        axes.push_back({{"name", a->name}, {"min", a->min}, {"max", a->max}, {"count", a->count}, {"texel", to_string(a->texel)}});
    j["layout"] = {{"fitted", p.fitted}, {"axes", axes}, {"roughness", p.spec.roughness}, {"channels_touched", p.channels_touched}};
    j["coverage"] = {{"rows", p.rows},       {"baked_rows", p.baked_rows},     {"slices", p.slices},
                     {"baked_slices", p.baked_slices}, {"texels", p.texels}, {"baked_texels", p.baked_texels},
                     {"touched_texels", p.touched_texels},
                     {"baked_fraction", p.texels ? double(p.baked_texels) / double(p.texels) : 0.0}};
    j["time"] = {{"scene_bake_seconds", r.bake.seconds}, {"full_bake_seconds", r.full_seconds},
                 {"ratio", r.full_seconds > 0 ? r.bake.seconds / r.full_seconds : 0.0},
                 {"default_lut_seconds", r.default_seconds}, {"reference_seconds", r.reference_seconds},
                 {"histogram_updates", r.bake.sample_node_rows}, {"full_histogram_updates", r.full_histogram_updates},
                 {"batches", r.bake.batches}, {"full_batches", r.full_batches},
                 {"device", r.bake.devices.empty() ? "" : r.bake.devices[0]}};
    j["bake"] = {{"max_std_error", r.bake.max_std_error}, {"batches", r.bake.batches}, {"samples_per_batch", r.bake.samples_per_batch},
                 {"azimuth_quadrature_error", r.bake.azimuth_quadrature_error}};
    json lights = json::array();
    for (std::size_t i = 0; i < domain.size(); ++i) {
        json l = {{"light", json_safe(domain[i].light)}, {"shaded_pixels", domain[i].shaded}, {"lookups", domain[i].lookups.size()}};
        if (i < r.errors.size()) {
            const auto& e = r.errors[i];
            l["errors"] = {{"scene_lut", json(e.scene_lut)},
                           {"default_lut", json(e.default_lut)},
                           {"azimuth_mean_floor", json(e.azimuth_floor)},
                           {"azimuth_mean_floor_bound", e.azimuth_floor_bound},
                           {"reference_bound", e.reference_bound},
                           {"sample", "an evenly strided sample of the lookups"}};
        }
        lights.push_back(l);
    }
    j["error_schema"] = kErrorSummarySchema;
    j["error_weighting"] = kLitErrorWeighting;
    j["lights"] = lights;
    if (!r.errors.empty())
        j["verdict"] = {{"default_serves", r.default_serves},
                        {"serve_error", r.serve_error},
                        {"rule", "the default LUT serves the scene when, for every light, its largest weighted error on the sampled "
                                 "lookups plus the reference's largest 99.9 % bound there is <= serve_error"},
                        {"default_lut", "seed-3d, " + std::to_string(r.default_size) + " texels per axis, the same sampling"}};
    return j;
}

std::string scene_bake_markdown(const SceneBakeResult& r, const std::vector<LightDomain>& domain) {
    const SceneBakePlan& p = r.plan;
    std::ostringstream m;
    m << "# bake --scene\n\n";
    m << "Layout: " << (p.fitted ? "fitted to the scene" : "the base layout") << ": visibility [" << format_g(p.spec.visibility.min) << ", "
      << format_g(p.spec.visibility.max) << "] x " << p.spec.visibility.count << ", NdotL [" << format_g(p.spec.n_dot_l.min) << ", "
      << format_g(p.spec.n_dot_l.max) << "] x " << p.spec.n_dot_l.count << ", NdotV [" << format_g(p.spec.n_dot_v.min) << ", "
      << format_g(p.spec.n_dot_v.max) << "] x " << p.spec.n_dot_v.count << ", roughness channels";
    for (double x : p.spec.roughness) m << " " << format_g(x);
    m << " (" << p.channels_touched.size() << " touched).\n\n";
    m << "| | count | of |\n|---|---|---|\n";
    m << "| slices (channel, NdotV) baked | " << p.baked_slices << " | " << p.slices << " |\n";
    m << "| rows baked | " << p.baked_rows << " | " << p.rows << " |\n";
    m << "| texels baked (whole rows) | " << p.baked_texels << " | " << p.texels << " (" << format_g(100.0 * double(p.baked_texels) / double(p.texels))
      << " %) |\n";
    m << "| texels in some lookup's footprint | " << p.touched_texels << " | " << p.texels << " |\n\n";
    m << "Time: scene bake " << format_g(r.bake.seconds) << " s";
    if (r.full_seconds > 0)
        m << ", full bake of the same layout " << format_g(r.full_seconds) << " s (ratio " << format_g(r.bake.seconds / r.full_seconds)
          << ", same run), default LUT " << format_g(r.default_seconds) << " s, reference " << format_g(r.reference_seconds) << " s";
    m << ".\n\n";
    if (r.full_histogram_updates)
        m << "Work (load-independent): histogram updates (samples x rows x azimuth nodes) " << r.bake.sample_node_rows << " of the full bake's "
          << r.full_histogram_updates << " (" << format_g(double(r.bake.sample_node_rows) / double(r.full_histogram_updates)) << "); normals passes "
          << r.bake.batches << " of " << r.full_batches << " (slice batches).\n\n";
    if (!r.errors.empty()) {
        m << "## Error on the scene (|LUT - reference| x N.L x intensity, sampled lookups)\n\n";
        m << "| light | LUT | lookups | lit max | lit RMS | lit p99 | term max | term RMS | reference bound |\n";
        m << "|---|---|---|---|---|---|---|---|---|\n";
        for (const auto& e : r.errors)
            for (const auto& [name, s] : {std::pair<std::string, const LitErrorSummary&>{"scene", e.scene_lut},
                                          std::pair<std::string, const LitErrorSummary&>{"default seed-3d-" + std::to_string(r.default_size), e.default_lut}})
                m << "| " << e.light << " | " << name << " | " << s.count << " | " << format_g(s.lit_max_abs) << " | " << format_g(s.lit_rms) << " | "
                  << format_g(s.lit_p99) << " | " << format_g(s.term_max_abs) << " | " << format_g(s.term_rms) << " | " << format_g(e.reference_bound) << " |\n";
        for (const auto& e : r.errors)
            if (e.azimuth_floor.count)
                m << "| " << e.light << " | azimuth-mean floor (any LUT of the azimuth mean) | " << e.azimuth_floor.count << " | "
                  << format_g(e.azimuth_floor.lit_max_abs) << " | " << format_g(e.azimuth_floor.lit_rms) << " | "
                  << format_g(e.azimuth_floor.lit_p99) << " | " << format_g(e.azimuth_floor.term_max_abs) << " | "
                  << format_g(e.azimuth_floor.term_rms) << " | " << format_g(e.azimuth_floor_bound)
                  << " (mean) |\n";
        m << "\n**Verdict:** the default LUT " << (r.default_serves ? "serves" : "does not serve") << " this scene within "
          << format_g(r.serve_error) << " (its largest weighted error on the sampled lookups plus the reference's bound).\n\n";
    }
    m << "## Domain\n\n| light | shaded pixels | lookups (lit) |";
    for (const auto& k : kHistograms) m << " " << k.name << " range |";
    m << "\n|---|---|---|---|---|---|---|---|\n";
    for (const auto& ld : domain) {
        m << "| " << ld.light << " | " << ld.shaded << " | " << ld.lookups.size() << " |";
        for (const auto& h : ld.histograms) m << " " << format_g(h.data_min) << " - " << format_g(h.data_max) << " |";
        m << "\n";
    }
    m << "\nHistograms: histograms_<light>.png, histograms.csv, histograms.json.\n";
    return m.str();
}

namespace {
void write_scene_bake_files(const SceneBakeResult& r, const std::vector<LightDomain>& domain, const std::string& lut_path,
                            const std::string& report_dir, const json& provenance);
}  // namespace

void write_scene_bake_outputs(const SceneBakeResult& r, const std::vector<LightDomain>& domain, const std::string& lut_path,
                              const std::string& report_dir, const json& provenance) {
    std::error_code ec;
    // The histogram images of the run that last wrote the folder (its report.json): those of lights this
    // run does not have are stale once the new set is in place.
    std::vector<std::string> before;
    if (std::ifstream in(fs::path(report_dir) / "report.json"); in) {
        try {
            const json previous = json::parse(in);  // named: a range over a temporary's member would dangle
            for (const auto& l : previous.at("lights")) before.push_back("histograms_" + file_name(l.at("light").get<std::string>()) + ".png");
        } catch (const std::exception&) {
            before.clear();
        }
    }
    const bool created = !fs::exists(report_dir, ec);
    fs::create_directories(report_dir, ec);
    if (ec) throw std::invalid_argument(report_dir + ": cannot create the report folder (" + ec.message() + ")");
    try {
        write_scene_bake_files(r, domain, lut_path, report_dir, provenance);
    } catch (...) {
        if (created) fs::remove(report_dir, ec);  // only if still empty
        throw;
    }
    for (const auto& f : before) {
        bool written = false;
        for (const auto& ld : domain) written = written || f == "histograms_" + file_name(ld.light) + ".png";
        if (!written && fs::is_regular_file(fs::path(report_dir) / f, ec)) fs::remove(fs::path(report_dir) / f, ec);
    }
}

namespace {

void write_scene_bake_files(const SceneBakeResult& r, const std::vector<LightDomain>& domain, const std::string& lut_path,
                            const std::string& report_dir, const json& provenance) {
    OutputSet out;
    const auto path = [&](const std::string& name) { return (fs::path(report_dir) / name).string(); };
    const std::size_t lut = out.add(lut_path, true);
    const std::size_t hist_json = out.add(path("histograms.json"));
    const std::size_t hist_csv = out.add(path("histograms.csv"));
    const std::size_t report_json = out.add(path("report.json"));
    const std::size_t report_md = out.add(path("report.md"));
    std::vector<std::size_t> pngs;
    for (const auto& ld : domain) pngs.push_back(out.add(path("histograms_" + file_name(ld.light) + ".png"), true));

    json meta = scene_lut_metadata(r.plan, r.bake);
    meta["scene"] = provenance.value("scene", "");
    write_lut(out.temp_path(lut), {r.plan.spec.visibility, r.plan.spec.n_dot_l, r.plan.spec.n_dot_v}, r.channels, r.bake.value, meta, false);

    json hist = json::array();
    std::ostream& csv = out.stream(hist_csv);
    csv << "light,histogram,unit,bin,bin_min,bin_max,count\n";
    for (std::size_t i = 0; i < domain.size(); ++i) {
        const LightDomain& ld = domain[i];
        json l = {{"light", json_safe(ld.light)}, {"lookups", ld.lookups.size()}, {"histograms", json::array()}};
        std::vector<HistogramPanel> panels;
        for (const Histogram& h : ld.histograms) {
            l["histograms"].push_back({{"name", h.name}, {"unit", h.unit}, {"min", h.min}, {"max", h.max}, {"counts", h.counts},
                                       {"data_min", h.data_min}, {"data_max", h.data_max}});
            const double w = (h.max - h.min) / double(h.counts.size());
            for (std::size_t b = 0; b < h.counts.size(); ++b)
                csv << csv_field(ld.light) << "," << h.name << ",\"" << h.unit << "\"," << b << "," << format_g(h.min + w * double(b), 6)
                    << "," << format_g(h.min + w * double(b + 1), 6) << "," << h.counts[b] << "\n";
            const char* label = h.name.c_str();
            for (const auto& k : kHistograms)
                if (h.name == k.name) label = k.label;
            panels.push_back({label, h.min, h.max, &h.counts, h.data_min, h.data_max});
        }
        hist.push_back(l);
        write_png_rgb(out.temp_path(pngs[i]),
                      render_histograms(panels, {"SCENE DOMAIN, LIGHT " + file_name(ld.light) + ": " + std::to_string(ld.lookups.size()) +
                                                 " LOOKUPS (SHADED, LIT PIXELS)"}));
    }
    out.stream(hist_json) << dump_json({{"lights", hist}, {"provenance", provenance}}, 1) << "\n";
    json report = scene_bake_report(r, domain);
    report["provenance"] = provenance;
    out.stream(report_json) << dump_json(report, 1) << "\n";
    out.stream(report_md) << scene_bake_markdown(r, domain);
    out.commit();
}

}  // namespace

}  // namespace ms::scene
