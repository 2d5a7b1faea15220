// The benchmarks of microshadow: a cached reference data set, throughput against C++
// baselines, run time against error, the LUT bake against a naive per-texel bake, and kernel build time.
// bench/main.cpp runs them from the command line; tests/bench/bench_smoke_test.cpp runs each at a tiny size.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace ms::bench {

// ---- reference data set --------------------------------------------------------------------------

// One reference value. kind 0: a query with an explicit light direction. kind 1: a texel of the
// seed-3d LUT (lut_x = visibility, lut_y = NdotL, lut_z = NdotV index, channel = roughness 0.1, 0.4,
// 0.7, 1.0, texel centres), whose value is the mean of the term over the relative azimuth in
// [0, 180] degrees; its `query` holds azimuth 0. error_bound holds with >= 99.9 % confidence.
struct RefEntry {
    int kind = 0;
    int lut_size = 0, lut_x = 0, lut_y = 0, lut_z = 0, channel = 0;
    Query query;
    double value = 0, std_error = 0, error_bound = 0;
};

struct ReferenceConfig {
    std::uint64_t query_samples = 1ull << 22;  // oracle samples per query
    std::uint64_t node_samples = 1ull << 19;   // oracle samples per azimuth node of a texel
    std::uint32_t replicates = 16;
    int azimuth_intervals = 16;  // trapezoid intervals over [0, pi] (a multiple of 2)
    int texels = 64;
    int lut_size = 64;
    std::uint64_t seed = 0x5eedf00dull;  // never used by a benchmark, so reference errors are independent
    unsigned threads = 0;                // oracle threads, 0: all
};

// The fixed design (entries without values): 48 queries and cfg.texels texels, all outside the zero region.
std::vector<RefEntry> reference_design(const ReferenceConfig& cfg);
// The query of texel (x, y, z, channel) of an n^3 seed-3d LUT at a relative azimuth (radians).
Query lut_texel_query(int x, int y, int z, int channel, int n, double azimuth);
// Computes the values with the scalar oracle (see reference.cpp for the error bound).
std::vector<RefEntry> make_reference(const ReferenceConfig& cfg, std::ostream& log);
// CSV with a JSON provenance file beside it (path + ".json"), both written atomically.
void write_reference(const std::string& path, const std::vector<RefEntry>& entries, const ReferenceConfig& cfg,
                     const std::string& command_line, double seconds);
std::vector<RefEntry> load_reference(const std::string& path);
// bench/data/reference.csv in the source tree.
std::string default_reference_path();

// ---- common ----------------------------------------------------------------------------------------

struct Options {
    std::string device = "default";
    std::string out_dir;  // where CSVs go; empty: none written
    bool smoke = false;   // tiny sizes: a test that the code runs, not a measurement
    std::ostream* log = nullptr;
    // The bake-speed benchmark's ladders (samples per slice) and repetitions.
    std::vector<std::uint64_t> speed_old_samples{4096, 16384, 65536}, speed_old_k8_samples{16384};
    std::vector<std::uint64_t> speed_new_samples{4096, 16384, 65536, 262144, 1048576}, speed_k16_samples{16384, 65536};
    std::vector<double> speed_old_tolerances{}, speed_new_tolerances{};
    int speed_reps = 3;
    std::size_t speed_tight_texels = 32;            // texels of the tight reference (0: none)
    std::uint64_t speed_tight_samples = 1ull << 22;  // its samples per azimuth node
};

// A result table: printed aligned, written as CSV.
struct Table {
    std::string name;
    std::vector<std::string> columns;
    std::vector<std::vector<std::string>> rows;
    void print(std::ostream& out) const;
    void write_csv(const std::string& path) const;
};
std::string fmt(double value, int precision = 4);

// ---- the benchmarks ------------------------------------------------------------------------------

struct ThroughputResult {
    Table table;
    double kernel_direct = 0, kernel_evaluate = 0, naive_kernel = 0, oracle_1t = 0, baseline_omp = 0;  // samples/s
    std::uint64_t max_count_difference = 0;  // kernel vs baseline, over the checked queries
    std::uint64_t max_borderline = 0;        // samples within float rounding of a threshold there
    bool tallies_agree = false;              // every difference <= its borderline count
};
ThroughputResult run_throughput(const Options& opt, const std::vector<RefEntry>& reference);

struct ErrorPoint {
    std::string method;
    std::uint64_t samples = 0;  // per value
    double seconds = 0, seconds_per_value = 0, max_error = 0, rms_error = 0, max_reported_error = 0;
    std::size_t values = 0;
};
std::vector<ErrorPoint> run_error_vs_time(const Options& opt, const std::vector<RefEntry>& reference);

struct BuildTimes {
    double cold_build = 0, cold_first_launch = 0;      // empty PoCL cache
    double cached_build = 0, cached_first_launch = 0;  // a new process over the filled PoCL cache
    double in_process_lookup = 0;                      // ms::ocl::Device's program cache
    double steady_launch = 0;                          // the same tiny launch once compiled
    std::string cache_dir;                             // the fresh POCL_CACHE_DIR (caller removes it)
    Table table;
};
// Must run before any other OpenCL use in the process: it points POCL_CACHE_DIR at a fresh directory.
BuildTimes run_build_time(const Options& opt, const std::string& self_exe);
// The child side of run_build_time: builds and launches once, prints "build=<s> launch=<s>".
int build_time_probe(const std::string& device);

struct BakeBenchResult {
    bool available = false;  // host/bake/bake.hpp present at build time
    Table table;
    double bake_seconds = 0, bake_max_error = 0, naive_seconds_per_texel = 0, naive_extrapolated = 0, speedup = 0;
};
BakeBenchResult run_bake(const Options& opt, const std::vector<RefEntry>& reference, std::vector<ErrorPoint>* error_points);

// Time-to-error curves of the bake, the azimuth-node quadrature (old) against the
// azimuth-stratified one (new), interleaved repetitions, both targets and a per-stage breakdown.
struct BakeSpeedResult {
    Table curves;
    std::string report;
    double speedup_1e3 = 0, seconds_1e4 = 0;
};
BakeSpeedResult run_bake_speed(const Options& opt, const std::vector<RefEntry>& reference);

// The exact evaluator's per-query path: isotropic queries through one azimuth grid per row against
// exact::exact_term per query (one thread, interleaved, 5 repeats): time per query, the ratio and the
// largest difference (absolute and over the sum of both estimates), on one-a-row and rows-of-9 sets.
Table run_exact_rows(const Options& opt);

}  // namespace ms::bench
