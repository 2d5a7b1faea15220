// microshadow_bench: the benchmarks. The documented command
//     build/bench/microshadow_bench --all --out docs/bench
// runs every benchmark in one process and writes docs/bench/{build_time,throughput,error_vs_time,bake}.csv
// and docs/bench/error_vs_time.png (scripts/plot_bench.py). The reference data set is regenerated with
//     build/bench/microshadow_bench --make-reference bench/data/reference.csv
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "bench.hpp"

namespace {

std::string self_exe() {
    char buf[4096];
    const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
    return n > 0 ? std::string(buf, std::size_t(n)) : std::string();
}

std::string join_args(int argc, char** argv) {
    std::string s;
    for (int i = 0; i < argc; ++i) s += (i ? " " : "") + std::string(argv[i]);
    return s;
}

void write_error_points(const std::string& path, const std::vector<ms::bench::ErrorPoint>& points) {
    ms::bench::Table t;
    t.name = "run time against error";
    t.columns = {"method", "samples_per_value", "seconds", "values", "seconds_per_value", "max_error", "rms_error",
                 "max_reported_std_error"};
    for (const auto& p : points)
        t.rows.push_back({p.method, std::to_string(p.samples), ms::bench::fmt(p.seconds, 5), std::to_string(p.values),
                          ms::bench::fmt(p.seconds_per_value, 5), ms::bench::fmt(p.max_error, 5),
                          ms::bench::fmt(p.rms_error, 5), ms::bench::fmt(p.max_reported_error, 5)});
    t.print(std::cout);
    if (!path.empty()) t.write_csv(path);
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"microshadow benchmarks: throughput, run time against error, LUT bake, kernel build time"};
    bool all = false, smoke = false, probe = false;
    std::string out_dir, device = "default", reference = ms::bench::default_reference_path(), make_reference;
    std::vector<std::string> only;
    app.add_flag("--all", all, "run every benchmark");
    app.add_option("--only", only, "run these benchmarks: build-time, throughput, error, bake, bake-speed, exact-rows")
        ->check(CLI::IsMember({"build-time", "throughput", "error", "bake", "bake-speed", "exact-rows"}));
    ms::bench::Options speed;
    app.add_option("--speed-old-tol", speed.speed_old_tolerances, "bake-speed: --tolerance values, old default")->delimiter(',');
    app.add_option("--speed-new-tol", speed.speed_new_tolerances, "bake-speed: --tolerance values, stratified K=32")->delimiter(',');
    app.add_option("--speed-reps", speed.speed_reps, "bake-speed: interleaved repetitions");
    app.add_option("--speed-tight", speed.speed_tight_texels, "bake-speed: texels of the tight reference (0: none)");
    app.add_option("--speed-tight-samples", speed.speed_tight_samples, "bake-speed: its samples per azimuth node");
    app.add_option("--speed-old", speed.speed_old_samples, "bake-speed: samples per slice of the old default")->delimiter(',');
    app.add_option("--speed-old-k8", speed.speed_old_k8_samples, "bake-speed: samples of the old --azimuth-intervals 8")->delimiter(',');
    app.add_option("--speed-new", speed.speed_new_samples, "bake-speed: samples of stratified K=32")->delimiter(',');
    app.add_option("--speed-k16", speed.speed_k16_samples, "bake-speed: samples of stratified K=16")->delimiter(',');
    app.add_option("--out", out_dir, "write the CSVs and the plot into this directory (must exist)")
        ->check(CLI::ExistingDirectory);
    app.add_option("--device", device, "OpenCL device: default|all|N|name");
    app.add_option("--reference", reference, "reference data set (CSV)")->check(CLI::ExistingFile);
    app.add_option("--make-reference", make_reference, "compute the reference data set with the oracle and write it here");
    app.add_flag("--smoke", smoke, "tiny sizes (checks the code runs; the figures mean nothing)");
    app.add_flag("--build-time-probe", probe, "internal: the child process of the build-time benchmark")->group("");
    CLI11_PARSE(app, argc, argv);

    try {
        if (probe) return ms::bench::build_time_probe(device);
        if (!make_reference.empty()) {
            const ms::bench::ReferenceConfig cfg;
            const auto start = std::chrono::steady_clock::now();
            const auto entries = ms::bench::make_reference(cfg, std::cerr);
            const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            ms::bench::write_reference(make_reference, entries, cfg, join_args(argc, argv), s);
            std::cerr << "reference: " << entries.size() << " values written to " << make_reference << " in " << s << " s\n";
            return 0;
        }
        auto wants = [&](const std::string& name) {
            return all || std::find(only.begin(), only.end(), name) != only.end();
        };
        if (!all && only.empty()) {
            std::cerr << "nothing to run: give --all, --only NAME or --make-reference PATH (see --help)\n";
            return 2;
        }
        ms::bench::Options opt = speed;
        opt.device = device;
        opt.out_dir = out_dir;
        opt.smoke = smoke;
        opt.log = &std::cerr;
        auto csv = [&](const std::string& name) { return out_dir.empty() ? std::string() : out_dir + "/" + name; };
        std::string pocl_cache;
        // Build time first: it must see an empty PoCL cache before anything else compiles a kernel.
        if (wants("build-time")) {
            const auto bt = ms::bench::run_build_time(opt, self_exe());
            pocl_cache = bt.cache_dir;
            bt.table.print(std::cout);
            if (!out_dir.empty()) bt.table.write_csv(csv("build_time.csv"));
        }
        const auto ref = ms::bench::load_reference(reference);
        if (wants("throughput")) {
            const auto tp = ms::bench::run_throughput(opt, ref);
            tp.table.print(std::cout);
            if (!out_dir.empty()) tp.table.write_csv(csv("throughput.csv"));
            if (!tp.tallies_agree) throw std::runtime_error("the C++ baseline does not compute what the kernel computes");
        }
        std::vector<ms::bench::ErrorPoint> points;
        if (wants("error")) points = ms::bench::run_error_vs_time(opt, ref);
        if (wants("bake")) {
            const auto bb = ms::bench::run_bake(opt, ref, wants("error") ? &points : nullptr);
            bb.table.print(std::cout);
            if (!out_dir.empty()) bb.table.write_csv(csv("bake.csv"));
            std::cout << "bake: fastest 64^3 x 4 bake at max error <= 1e-3: " << ms::bench::fmt(bb.bake_seconds, 4)
                      << " s (target 2 s); naive per-texel bake: " << ms::bench::fmt(bb.naive_extrapolated, 4)
                      << " s; speed-up " << ms::bench::fmt(bb.speedup, 4) << "x (target 10000x)\n";
        }
        if (wants("exact-rows")) {
            const auto er = ms::bench::run_exact_rows(opt);
            er.print(std::cout);
            if (!out_dir.empty()) er.write_csv(csv("exact_rows.csv"));
        }
        // Not part of --all (several minutes): --only bake-speed.
        if (std::find(only.begin(), only.end(), "bake-speed") != only.end()) {
            const auto bs = ms::bench::run_bake_speed(opt, ref);
            bs.curves.print(std::cout);
            std::cout << bs.report;
            if (!out_dir.empty()) {
                bs.curves.write_csv(csv("bake_time_to_error.csv"));
                std::ofstream(csv("bake_speed_report.txt")) << bs.report;
                const std::string cmd = "/usr/bin/python3 '" + std::string(MICROSHADOW_BENCH_DIR) +
                                        "/plot_bake_time_to_error.py' '" + csv("bake_time_to_error.csv") + "' '" +
                                        csv("bake_time_to_error.png") + "'";
                if (std::system(cmd.c_str()) != 0) throw std::runtime_error("plotting failed: " + cmd);
            }
        }
        if (!points.empty()) {
            write_error_points(csv("error_vs_time.csv"), points);
            if (!out_dir.empty()) {
                // Debian's matplotlib lives under /usr/bin/python3 (the python3 on PATH may be another).
                const std::string cmd = "/usr/bin/python3 '" + std::string(MICROSHADOW_BENCH_DIR) +
                                        "/../scripts/plot_bench.py' '" + csv("error_vs_time.csv") + "' '" +
                                        csv("error_vs_time.png") + "'";
                if (std::system(cmd.c_str()) != 0) throw std::runtime_error("plotting failed: " + cmd);
            }
        }
        if (!pocl_cache.empty()) std::filesystem::remove_all(pocl_cache);
    } catch (const std::exception& e) {
        std::cerr << "microshadow_bench: error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
