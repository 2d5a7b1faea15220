#include "integrands/lut_slice/lut_slice_integrand.hpp"

#include "schedule/item_bytes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "core/cancel.hpp"
#include "core/seeds.hpp"
#include "microshadow_shared.h"
#include "oracle/oracle.hpp"
#include "schedule/item_bytes.hpp"

namespace ms::lut_slice {

static_assert(sizeof(ms_bake_slice) == 64, "ms_bake_slice layout must match the OpenCL C struct");

namespace {

// Local sizes of the bake kernels, fixed instead of left to the runtime (NullRange): given NullRange,
// PoCL 3.1 chose a new local size for every new global size (the adaptive azimuth makes many) and
// compiled a work-group function for each: 84 compilations, +10 s in a cold-cache 64^3 bake (16.9 s
// vs 4.5 s at 4096 samples). 8, 16, 32 measured alike on PoCL; 32 is also a warp on NVIDIA.
constexpr std::size_t kNormalsLocalSize = 32, kHistogramLocalSize = 32;

// The fields of the kernel's slice argument that every slice shares.
ms_bake_slice base_arguments(const SlicePlan& plan) {
    ms_bake_slice b{};
    const Axis& vis = plan.spec.visibility;
    b.vis_min = float(vis.min);
    const double range = vis.max - vis.min;
    // v_j = vis_min + (j + offset) / scale for both conventions (and a lone endpoint texel at min).
    if (vis.texel == TexelConvention::centres) {
        b.bin_scale = float(plan.nv / range);
        b.bin_offset = 0.5f;
    } else {
        b.bin_scale = plan.nv > 1 ? float((plan.nv - 1) / range) : 1.0f;
        b.bin_offset = 0.0f;
    }
    b.points = plan.points;
    b.replicates = plan.replicates;
    b.directions = std::uint32_t(plan.directions());
    b.texels = plan.nv;
    b.ao_weighting = plan.spec.term.ao_weighting == AoWeighting::cosine ? MS_AO_COSINE : MS_AO_UNIFORM;
    b.cell_points = plan.cells ? plan.points / plan.cells : 0;
    return b;
}

std::string gib(std::uint64_t bytes) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g GiB", double(bytes) / double(1ull << 30));
    return b;
}

// The kernel routine: one device's buffers and kernels, reused across the slices it runs.
class DeviceSliceTallier final : public SliceTallier {
public:
    DeviceSliceTallier(ocl::Device& device, const SlicePlan& plan) : device_(device), plan_(plan), base_(base_arguments(plan)) {
        ocl::require_build_support(device_.info(), plan.spec.build);
        // Buffers a device cannot hold are refused here, named, with the device's limits.
        const MemoryEstimate need = memory_estimate(plan, 1);
        const ocl::DeviceInfo& info = device_.info();
        for (const auto& [name, bytes] : need.device_buffers)
            if (info.max_alloc && bytes > info.max_alloc)
                throw std::invalid_argument("the bake's " + name + " buffer needs " + gib(bytes) + ", more than the " +
                                            gib(info.max_alloc) + " one buffer may have on " + info.label() +
                                            "; use fewer texels or samples");
        if (info.global_memory && need.device_bytes() > info.global_memory)
            throw std::invalid_argument("the bake needs " + gib(need.device_bytes()) + " on the device, more than the " +
                                        gib(info.global_memory) + " of " + info.label());
        const std::size_t real_size = plan.spec.build.double_precision ? sizeof(double) : sizeof(float);
        ocl::checked([&] {
            normals_ = device_.kernel("lut_slice/lut_slice.cl", "ms_bake_normals", plan.spec.build);
            histogram_ = device_.kernel("lut_slice/lut_slice.cl", "ms_bake_histogram", plan.spec.build);
            const std::size_t total = std::size_t(plan.points) * plan.replicates;
            normals_local_ = ocl::local_size(normals_, device_.info(), kNormalsLocalSize);
            histogram_local_ = ocl::local_size(histogram_, device_.info(), kHistogramLocalSize);
            const std::size_t items = ocl::round_up(plan.directions() * plan.replicates, histogram_local_);
            wo_ = cl::Buffer(device_.context(), CL_MEM_READ_ONLY, plan.wo.size() * sizeof(float));
            for (auto* b : {&nx_, &ny_, &nz_}) *b = cl::Buffer(device_.context(), CL_MEM_READ_WRITE, total * real_size);
            scratch_ = cl::Buffer(device_.context(), CL_MEM_READ_WRITE,
                                  items * MS_BAKE_SUBHISTOGRAMS * (plan.nv + 2) * sizeof(cl_uint));
            counts_ = cl::Buffer(device_.context(), CL_MEM_WRITE_ONLY, items * (plan.nv + 1) * sizeof(cl_uint));
            return 0;
        });
    }

    void begin_batch(std::uint32_t channel, std::uint32_t ivv, const PointSet& points) override {
        const Query q = texel_query(plan_.spec, channel, 0, 0, ivv, 0);
        slice_ = base_;
        slice_.alpha_x = slice_.alpha_y = float(q.alpha_x);
        slice_.wi_x = float(q.wi.x), slice_.wi_y = float(q.wi.y), slice_.wi_z = float(q.wi.z);
        ocl::checked([&] {
            // Keep one uploaded point set: a bake walks batches 0, 1, ... per slice, and every upload is
            // small next to the slice's histogram work (a map of every batch grew without bound).
            if (uploaded_ != &points || uploaded_seed_ != points.seed) {
                const ocl::PointBuffers b = ocl::upload_points(device_, points.u1, points.u2);
                u1_ = b.u1;
                u2_ = b.u2;
                uploaded_ = &points;
                uploaded_seed_ = points.seed;
            }
            normals_.setArg(0, slice_);
            normals_.setArg(1, u1_);
            normals_.setArg(2, u2_);
            normals_.setArg(3, nx_);
            normals_.setArg(4, ny_);
            normals_.setArg(5, nz_);
            const std::size_t blocks = std::size_t(plan_.points) / MS_LANES * plan_.replicates;
            device_.queue().enqueueNDRangeKernel(normals_, cl::NullRange, cl::NDRange(ocl::round_up(blocks, normals_local_)),
                                                 cl::NDRange(normals_local_));
            // Waited for here so that the slice report can tell the normals pass from the histograms.
            device_.queue().finish();
            return 0;
        });
    }

    void add_counts(const std::vector<std::uint32_t>& dirs, SliceTallies& acc) override {
        const std::size_t R = plan_.replicates, stride = plan_.nv + 1;
        const std::size_t items = dirs.size() * R;
        std::vector<float> wo(dirs.size() * 4);
        for (std::size_t d = 0; d < dirs.size(); ++d) std::copy_n(&plan_.wo[std::size_t(dirs[d]) * 4], 4, &wo[d * 4]);
        std::vector<cl_uint> counts(items * stride);
        ms_bake_slice slice = slice_;
        slice.directions = std::uint32_t(dirs.size());
        ocl::checked([&] {
            device_.queue().enqueueWriteBuffer(wo_, CL_FALSE, 0, wo.size() * sizeof(float), wo.data());
            histogram_.setArg(0, slice);
            histogram_.setArg(1, wo_);
            histogram_.setArg(2, nx_);
            histogram_.setArg(3, ny_);
            histogram_.setArg(4, nz_);
            histogram_.setArg(5, scratch_);
            histogram_.setArg(6, counts_);
            device_.queue().enqueueNDRangeKernel(histogram_, cl::NullRange, cl::NDRange(ocl::round_up(items, histogram_local_)),
                                                 cl::NDRange(histogram_local_));
            device_.queue().enqueueReadBuffer(counts_, CL_TRUE, 0, counts.size() * sizeof(cl_uint), counts.data());
            return 0;
        });
        for (std::size_t d = 0; d < dirs.size(); ++d) {
            const cl_uint* from = &counts[d * R * stride];
            double* to = &acc[std::size_t(dirs[d]) * R * stride];
            for (std::size_t i = 0; i < R * stride; ++i) to[i] += from[i];
        }
    }

private:
    ocl::Device& device_;
    const SlicePlan& plan_;
    const ms_bake_slice base_;
    ms_bake_slice slice_{};
    std::size_t normals_local_ = 1, histogram_local_ = 1;
    cl::Kernel normals_, histogram_;
    cl::Buffer wo_, nx_, ny_, nz_, scratch_, counts_, u1_, u2_;
    const PointSet* uploaded_ = nullptr;
    std::uint64_t uploaded_seed_ = 0;
};

// The oracle: every sampled texel of a direction tallied on its own by oracle::tally (weights kept,
// cosines and libm trigonometry in double, the light direction in double), which shares no formula
// with the histogram kernel. The hemisphere tally does not depend on the visibility, so a row's is
// taken from its first sampled texel. Stratified plans: a (row, cell) direction is tallied at the cell's
// midpoint azimuth on the cell's points only (a point set of n / cells points per replicate, copied out
// of the cell-major batch).
class OracleSliceTallier final : public SliceTallier {
public:
    explicit OracleSliceTallier(const SlicePlan& plan) : plan_(plan) {}
    void begin_batch(std::uint32_t channel, std::uint32_t ivv, const PointSet& points) override {
        channel_ = channel;
        ivv_ = ivv;
        points_ = &points;
        cell_points_.clear();
        if (!plan_.cells) return;
        const std::uint32_t n = points.points_per_replicate, per_cell = n / plan_.cells;
        for (std::uint32_t c = 0; c < plan_.cells; ++c) {
            PointSet cell;
            cell.sequence = points.sequence;
            cell.replicates = points.replicates;
            cell.points_per_replicate = per_cell;
            cell.seed = points.seed;
            for (std::uint32_t r = 0; r < points.replicates; ++r) {
                const std::size_t from = std::size_t(r) * n + std::size_t(c) * per_cell;
                cell.u1.insert(cell.u1.end(), points.u1.begin() + from, points.u1.begin() + from + per_cell);
                cell.u2.insert(cell.u2.end(), points.u2.begin() + from, points.u2.begin() + from + per_cell);
            }
            cell_points_.push_back(std::move(cell));
        }
    }
    void add_counts(const std::vector<std::uint32_t>& dirs, SliceTallies& acc) override {
        const std::size_t R = plan_.replicates, stride = plan_.nv + 1, nodes = plan_.row_directions();
        for (std::uint32_t d : dirs) {
            const std::uint32_t il = std::uint32_t(d / nodes), node = std::uint32_t(d % nodes);
            const PointSet& points = plan_.cells ? cell_points_[node] : *points_;
            bool hemisphere_done = false;
            for (std::uint32_t iv = 0; iv < plan_.nv; ++iv) {
                if (plan_.texel(il, iv) != sampled) continue;
                const Query q = texel_query(plan_.spec, channel_, iv, il, ivv_, plan_.node_degrees[node]);
                const oracle::Tally t = oracle::tally(q, plan_.spec.term, points);
                for (std::size_t r = 0; r < R; ++r) {
                    double* row = &acc[(std::size_t(d) * R + r) * stride];
                    row[iv] += t.cone[r];
                    if (!hemisphere_done) row[plan_.nv] += t.hemisphere[r];
                }
                hemisphere_done = true;
            }
        }
    }

private:
    const SlicePlan& plan_;
    std::uint32_t channel_ = 0, ivv_ = 0;
    const PointSet* points_ = nullptr;
    std::vector<PointSet> cell_points_;
};

class SliceWorker final : public schedule::Worker {
public:
    SliceWorker(LutSliceIntegrand& integrand, std::unique_ptr<SliceTallier> tallier)
        : integrand_(integrand), tallier_(std::move(tallier)) {}
    void run(std::uint64_t id) override { integrand_.run_slice(id, tallier_.get()); }

private:
    LutSliceIntegrand& integrand_;
    std::unique_ptr<SliceTallier> tallier_;
};

}  // namespace

std::uint64_t MemoryEstimate::device_bytes() const {
    std::uint64_t sum = 0;
    for (const auto& b : device_buffers) sum += b.second;
    return sum;
}

MemoryEstimate memory_estimate(const SlicePlan& plan, std::size_t places) {
    const std::uint64_t real = plan.spec.build.double_precision ? 8 : 4;
    const std::uint64_t samples = plan.batch_samples, stride = plan.nv + 1;
    // The histogram kernel's work-items: (direction, replicate) pairs of the largest launch.
    const std::uint64_t items = std::uint64_t(plan.directions()) * plan.replicates + kHistogramLocalSize;
    MemoryEstimate m;
    m.device_buffers = {{"normals", 3 * samples * real},
                        {"points", 2 * samples * 4},
                        {"histogram scratch", items * MS_BAKE_SUBHISTOGRAMS * (plan.nv + 2) * 4},
                        {"counts", items * stride * 4},
                        {"light directions", plan.wo.size() * 4}};
    // Host: the atlas (values and errors), and per place a slice's tallies (double), the counts read
    // back, the slice's texels, and the recent point sets (shared_point_set keeps 4).
    const std::uint64_t atlas = plan.atlas().texels() * 2 * 4;
    const std::uint64_t per_place = plan.tally_size() * 8 + items * stride * 4 + std::uint64_t(plan.nl) * plan.nv * 8;
    m.host_bytes = atlas + places * per_place + 4 * samples * 8;
    return m;
}

LutSliceIntegrand::LutSliceIntegrand(const LutSliceSpec& spec) : plan_(make_slice_plan(spec)) {
    validate(spec);
    any_sampled_ = std::find(plan_.status.begin(), plan_.status.end(), sampled) != plan_.status.end();
    const std::size_t texels = plan_.atlas().texels();
    value_.assign(texels, 0.0f);
    std_error_.assign(texels, 0.0f);
    reports_.resize(plan_.slices());
}

std::unique_ptr<schedule::Worker> LutSliceIntegrand::device_worker(ocl::Device& device) {
    // A bake whose every texel is exact needs no kernels (and no device build).
    if (!any_sampled_) return std::make_unique<SliceWorker>(*this, nullptr);
    return std::make_unique<SliceWorker>(*this, std::make_unique<DeviceSliceTallier>(device, plan_));
}

std::unique_ptr<schedule::Worker> LutSliceIntegrand::oracle_worker() {
    return std::make_unique<SliceWorker>(*this, std::make_unique<OracleSliceTallier>(plan_));
}

std::shared_ptr<const PointSet> LutSliceIntegrand::batch_points(std::uint32_t batch) const {
    SamplingPlan p;
    p.sequence = plan_.spec.sequence;
    p.samples = plan_.batch_samples;
    p.replicates = plan_.replicates;
    p.seed = batch_seed(plan_.spec.seed, batch);
    // shared_point_set keeps the few most recent sets: every slice starts with batch 0, and memory stays
    // bounded however many batches a tolerance asks for.
    return shared_point_set(p, plan_.cells);
}

void LutSliceIntegrand::run_slice(std::uint64_t id, SliceTallier* tallier) {
    const SlicePlan& plan = plan_;
    // Slice order: channel = slice % channels, NdotV index = slice / channels.
    const std::uint32_t channel = std::uint32_t(id % plan.channels);
    const std::uint32_t ivv = std::uint32_t(id / plan.channels);
    SliceReport report;
    SliceTallies acc(any_sampled_ ? plan.tally_size() : 0, 0.0);
    // Intervals per NdotL row: every row starts at k_start; rows with no sampled texel need no tallies.
    std::vector<std::uint32_t> k(plan.nl, plan.k_start);
    std::vector<std::uint8_t> row_sampled(plan.nl, 0);
    // A partial bake (spec.baked_rows) samples only its rows; the others are marked NaN below.
    bool any_row_baked = false;
    for (std::uint32_t il = 0; il < plan.nl; ++il) any_row_baked |= plan.spec.row_baked(id, il);
    if (!any_row_baked) {
        for (std::uint32_t il = 0; il < plan.nl; ++il)
            for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
                const std::size_t at = plan.atlas().index(channel, iv, il, ivv);
                value_[at] = std_error_[at] = std::numeric_limits<float>::quiet_NaN();
            }
        report.done = true;
        reports_[id] = std::move(report);
        return;
    }
    for (std::uint32_t il = 0; il < plan.nl; ++il) row_sampled[il] = plan.row_sampled(il) && plan.spec.row_baked(id, il);
    SliceValues local;
    local.value.assign(std::size_t(plan.nl) * plan.nv, 0.0f);
    local.std_error.assign(local.value.size(), 0.0f);
    if (any_sampled_) {
        auto run = [&](const std::vector<std::uint32_t>& dirs) {
            if (dirs.empty()) return;
            const auto start = std::chrono::steady_clock::now();
            tallier->add_counts(dirs, acc);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            report.device_seconds += seconds;
            report.histogram_seconds += seconds;
            report.histogram_updates += std::uint64_t(dirs.size()) * plan.batch_samples / std::max(1u, plan.cells);
        };
        std::vector<std::uint32_t> dirs;
        for (std::uint32_t batch = 0;; ++batch) {
            throw_if_cancelled();
            const auto batch_start = std::chrono::steady_clock::now();
            const auto points = batch_points(batch);
            tallier->begin_batch(channel, ivv, *points);
            const double normals = std::chrono::duration<double>(std::chrono::steady_clock::now() - batch_start).count();
            report.device_seconds += normals;
            report.normals_seconds += normals;
            dirs.clear();
            for (std::uint32_t il = 0; il < plan.nl; ++il)
                if (row_sampled[il] && plan.cells)
                    for (std::uint32_t c = 0; c < plan.cells; ++c) dirs.push_back(il * plan.cells + c);
                else if (row_sampled[il])
                    for (std::uint32_t i = 0; i <= k[il]; ++i) dirs.push_back(il * (plan.grid + 1) + row_node(plan, k[il], i));
            run(dirs);
            // Adaptive azimuth (batch 0 only; later batches keep the rows' nodes): a row whose check is
            // significant gets the k new midpoint nodes of 2k.
            if (batch == 0 && plan.k_start < plan.grid) {
                std::vector<std::uint8_t> open = row_sampled;
                for (;;) {
                    throw_if_cancelled();
                    dirs.clear();
                    for (std::uint32_t il = 0; il < plan.nl; ++il) {
                        if (!open[il]) continue;
                        bool refine = false;
                        if (k[il] < plan.grid) row_quadrature(plan, acc, il, k[il], plan.refine_threshold, plan.refine_z, &refine);
                        if (!refine) {
                            open[il] = 0;
                            continue;
                        }
                        k[il] *= 2;
                        for (std::uint32_t i = 1; i < k[il]; i += 2) dirs.push_back(il * (plan.grid + 1) + row_node(plan, k[il], i));
                    }
                    if (dirs.empty()) break;
                    run(dirs);
                }
            }
            report.batches = batch + 1;
            const auto reduce_start = std::chrono::steady_clock::now();
            report.max_std_error = reduce_slice(plan, acc, k, local);
            report.reduce_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - reduce_start).count();
            const double tol = plan.spec.tolerance;
            if (tol <= 0 || report.max_std_error <= tol || report.batches >= plan.spec.max_batches) break;
        }
        for (std::uint32_t il = 0; il < plan.nl; ++il)
            if (row_sampled[il]) report.quadrature_error = std::max(report.quadrature_error, row_quadrature(plan, acc, il, k[il]));
    } else {
        reduce_slice(plan, acc, k, local);
    }
    // Stratified rows have no intervals (BakeResult::azimuth_cells says what they used).
    if (!plan.cells)
        for (std::uint32_t il = 0; il < plan.nl; ++il) report.row_intervals.push_back(row_sampled[il] ? int(k[il]) : -1);
    // Each slice writes only its own texels, so workers on different places never touch the same floats.
    // Rows a partial bake leaves out hold NaN, never a value (their tallies are empty).
    for (std::uint32_t il = 0; il < plan.nl; ++il) {
        const bool baked = plan.spec.row_baked(id, il);
        for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
            const std::size_t at = plan.atlas().index(channel, iv, il, ivv);
            value_[at] = baked ? local.value[std::size_t(il) * plan.nv + iv] : std::numeric_limits<float>::quiet_NaN();
            std_error_[at] = baked ? local.std_error[std::size_t(il) * plan.nv + iv] : std::numeric_limits<float>::quiet_NaN();
        }
    }
    report.done = true;
    reports_[id] = std::move(report);
}

// The slice's texels in row order, then its report (timings included: they are the slice's own).
std::string LutSliceIntegrand::save_item(std::uint64_t id) const {
    const std::uint32_t channel = std::uint32_t(id % plan_.channels), ivv = std::uint32_t(id / plan_.channels);
    const SliceReport& r = reports_.at(id);
    schedule::ItemWriter w;
    std::vector<float> value, error;
    for (std::uint32_t il = 0; il < plan_.nl; ++il)
        for (std::uint32_t iv = 0; iv < plan_.nv; ++iv) {
            const std::size_t at = plan_.atlas().index(channel, iv, il, ivv);
            value.push_back(value_[at]);
            error.push_back(std_error_[at]);
        }
    w.put_vector(value);
    w.put_vector(error);
    for (double d : {r.max_std_error, r.quadrature_error, r.device_seconds, r.normals_seconds, r.histogram_seconds,
                     r.reduce_seconds})
        w.put(d);
    w.put(r.batches);
    w.put(r.histogram_updates);
    w.put_vector(r.row_intervals);
    return w.take();
}

void LutSliceIntegrand::load_item(std::uint64_t id, const std::string& bytes) {
    if (id >= work_items()) throw std::runtime_error("LUT slice " + std::to_string(id) + ": no such slice");
    const std::uint32_t channel = std::uint32_t(id % plan_.channels), ivv = std::uint32_t(id / plan_.channels);
    schedule::ItemReader r(bytes, "LUT slice " + std::to_string(id));
    const std::uint64_t texels = std::uint64_t(plan_.nl) * plan_.nv;
    const std::vector<float> value = r.get_vector<float>(texels), error = r.get_vector<float>(texels);
    SliceReport report;
    for (double* d : {&report.max_std_error, &report.quadrature_error, &report.device_seconds, &report.normals_seconds,
                      &report.histogram_seconds, &report.reduce_seconds})
        *d = r.get<double>();
    report.batches = r.get<std::uint32_t>();
    report.histogram_updates = r.get<std::uint64_t>();
    // Rows of a nodes-quadrature bake each record their intervals; a stratified one, or a slice a partial
    // bake leaves out, records none.
    report.row_intervals = r.get_vector<int>(plan_.cells ? 0 : plan_.nl, true);
    r.finish();
    if (const std::string problem = schedule::check_fraction_texels(value, error, plan_.nl, plan_.nv,
                                                                    [&](std::uint32_t il) { return plan_.spec.row_baked(id, il); });
        !problem.empty())
        throw std::runtime_error("LUT slice " + std::to_string(id) + ": " + problem);
    for (std::uint32_t il = 0; il < plan_.nl; ++il)
        for (std::uint32_t iv = 0; iv < plan_.nv; ++iv) {
            const std::size_t at = plan_.atlas().index(channel, iv, il, ivv);
            value_[at] = value[std::size_t(il) * plan_.nv + iv];
            std_error_[at] = error[std::size_t(il) * plan_.nv + iv];
        }
    report.done = true;
    reports_[id] = std::move(report);
}

}  // namespace ms::lut_slice

namespace ms::lut_slice {

std::string LutSliceIntegrand::check_item(std::uint64_t id, const std::string& bytes) const {
    if (id >= work_items()) return "index: no slice " + std::to_string(id);
    try {
        schedule::ItemReader r(bytes, "LUT slice " + std::to_string(id));
        const std::uint64_t texels = std::uint64_t(plan_.nl) * plan_.nv;
        const std::vector<float> value = r.get_vector<float>(texels), error = r.get_vector<float>(texels);
        for (int k = 0; k < 6; ++k)
            if (const double d = r.get<double>(); d < 0 || std::isinf(d)) return "values: a report figure is " + std::to_string(d);
        r.get<std::uint32_t>();
        r.get<std::uint64_t>();
        r.get_vector<int>(plan_.cells ? 0 : plan_.nl, true);
        r.finish();
        return schedule::check_fraction_texels(value, error, plan_.nl, plan_.nv, [&](std::uint32_t il) { return plan_.spec.row_baked(id, il); });
    } catch (const std::exception& e) {
        return std::string("payload: ") + e.what();
    }
}

}  // namespace ms::lut_slice
