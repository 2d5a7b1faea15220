// Reliability of design, sweep inputs, representation files and the estimate's error bar:
//   - replicates that agree exactly get the binomial bound as their error, also for an interior term;
//   - the design reference cache checks its files (digests, rows, ranges), sets damaged ones aside and
//     recomputes them; a second run on the same cache waits for the first instead of losing its chunks;
//   - a design run refuses bad sampling, bad names and malformed budgets before any work;
//   - representation files with texels outside their range or channels that are not the grid's are refused;
//   - a sweep names a missing or damaged comparator file before starting the devices;
//   - eval, bake, sweep, repr bake and design give identical outputs when one of two devices fails, and a
//     run stopped by SIGTERM leaves no temporary or mixed file: the rerun gives the clean run's bytes.
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "cli_runner.hpp"
#include "core/estimate.hpp"
#include "io/exr_file.hpp"
#include "jobs/design.hpp"
#include "jobs/eval.hpp"
#include "jobs/reference_set.hpp"
#include "lut/exr_lut.hpp"
#include "repr/representation.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::ChildRun;
using ms::testing::run_microshadow;
using ms::testing::slurp_file;

class DesignReliability : public ms::testing::ScratchDirTest {
protected:
    DesignReliability() : ScratchDirTest("design_rel") {}
    ChildRun cli(const std::string& args, const std::string& env = "") { return run_microshadow(dir_, args, env); }
};

// ---------------------------------------------------------------------------------------------------
// The error bar of agreeing replicates.

// P(X <= k) for X ~ Binomial(n, p), summed term by term (independent of the incomplete beta).
double binomial_cdf(int k, int n, double p) {
    double sum = 0;
    for (int i = 0; i <= k; ++i)
        sum += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) + i * std::log(p) +
                        (n - i) * std::log1p(-p));
    return sum;
}

TEST(AgreementBound, IsTheClopperPearsonIntervalAndTheZeroBoundAtTheEnds) {
    // At 0 and n passes it is the one-sided bound, bit for bit (the golden outputs keep their errors).
    for (double n : {16.0, 8192.0, 65536.0}) {
        EXPECT_EQ(ms::binomial_agreement_bound(0, n, 0.999), ms::binomial_zero_bound(n, 0.999));
        EXPECT_EQ(ms::binomial_agreement_bound(n, n, 0.999), ms::binomial_zero_bound(n, 0.999));
    }
    // Inside: the ends of the exact interval, found here by bisection on the summed binomial CDF.
    const double tail = 0.0005;
    for (const auto& [k, n] : std::vector<std::pair<int, int>>{{1, 20}, {3, 40}, {57, 64}, {199, 200}, {500, 1000}}) {
        double lo_a = 0, lo_b = double(k) / n, hi_a = double(k) / n, hi_b = 1;
        for (int i = 0; i < 200; ++i) {
            const double m = 0.5 * (lo_a + lo_b);
            (1 - binomial_cdf(k - 1, n, m) < tail ? lo_a : lo_b) = m;  // P(X >= k | p_lo) = tail
            const double h = 0.5 * (hi_a + hi_b);
            (binomial_cdf(k, n, h) > tail ? hi_a : hi_b) = h;  // P(X <= k | p_hi) = tail
        }
        const double f = double(k) / n;
        const double expected = std::max(hi_b - f, f - lo_a);
        const double got = ms::binomial_agreement_bound(k, n, 0.999);
        // Both sides evaluate the same tails in double (lgamma and a continued fraction against a sum of
        // n terms): they agree to about 1e-13 in the tail, far inside 1e-9 of the bound.
        EXPECT_NEAR(got, expected, 1e-9 * expected) << k << " of " << n;
    }
}

TEST_F(DesignReliability, AnInteriorTermWhoseReplicatesAgreeHasANonZeroErrorBarThatHoldsTheTruth) {
    // v 0.95, alpha 0.05, wi = wo = normal: every replicate of the default point set fails exactly one
    // of its 8192 samples, so the replicate spread is 0 while the term is 0.9998685 (1 - 1.315e-4, from
    // eval --method sampled --samples 16777216 --seed 7: 0.99986845 +- 6e-8; the agreeing estimate is 1 - 1/8192 = 0.9998779).
    {
        std::ofstream q(path("q.csv"));
        q << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0.95,0.05,0.05,0,0,1,0,0,1\n";
    }
    const ChildRun r = cli("eval --method sampled --in q.csv --out r.csv -q");
    ASSERT_EQ(r.exit_code, 0) << r.log;
    std::ifstream in(path("r.csv"));
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    std::vector<double> f;
    std::stringstream ss(row);
    for (std::string field; std::getline(ss, field, ',');) f.push_back(std::stod(field));
    ASSERT_EQ(f.size(), 11u) << row;
    const double term = f[9], se = f[10];
    EXPECT_NEAR(term, 1 - 1.0 / 8192, 1e-12) << "the replicates no longer agree here; pick another query";
    EXPECT_GT(se, 0) << row;
    const double bar = ms::student_t_quantile(0.999, 7) * se;
    EXPECT_LE(std::abs(term - 0.9998685), bar) << row;
    // The bar is the exact interval's: 8 failures in 65536 samples, not a guess.
    EXPECT_NEAR(bar, ms::binomial_agreement_bound(65536 - 8, 65536, 0.999), 1e-12);
}

// ---------------------------------------------------------------------------------------------------
// The design reference cache.

ms::design::ReferenceDefinition small_reliability_definition() {
    ms::design::ReferenceDefinition d;
    d.name = "small";
    d.count = 40;
    d.plan.samples = 1024;
    d.plan.replicates = 8;
    d.backend_label = "oracle";
    return d;
}

// Replaces the term of data line `line` (1-based after the header, or of a chunk) with `term`.
void rewrite_term(const std::string& file, std::size_t line, const std::string& term) {
    std::ifstream in(file);
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    in.close();
    std::string& l = lines.at(line);
    std::vector<std::string> f;
    std::stringstream ss(l);
    for (std::string field; std::getline(ss, field, ',');) f.push_back(field);
    ASSERT_EQ(f.size(), 8u) << l;
    f[6] = term;
    l.clear();
    for (std::size_t i = 0; i < f.size(); ++i) l += (i ? "," : "") + f[i];
    std::ofstream out(file, std::ios::trunc);
    for (const auto& x : lines) out << x << "\n";
}

TEST_F(DesignReliability, ChangedRowsOfTheReferenceCacheAreSetAsideAndRecomputed) {
    auto backend = ms::make_oracle_backend(2);
    const auto def = small_reliability_definition();
    ms::design::CacheConfig config;
    config.dir = path("cache");
    config.backend = backend.get();
    config.chunk_points = 16;
    const auto clean = ms::design::load_or_compute(def, config);
    const std::string file = clean.file;
    // A plausible change (a term still in [0, 1]) and an impossible one (1.5): both are caught, the
    // file goes to rejected/, and the set computed again has the clean values.
    for (const std::string term : {"0.123", "1.5"}) {
        rewrite_term(file, 7, term);
        std::vector<std::string> warnings;
        ms::design::CacheConfig c = config;
        c.warn = [&](const std::string& w) { warnings.push_back(w); };
        ms::design::CacheReport report;
        const auto again = ms::design::load_or_compute(def, c, &report);
        EXPECT_FALSE(report.from_cache) << term;
        ASSERT_EQ(warnings.size(), 1u) << term;
        EXPECT_NE(warnings[0].find(file), std::string::npos) << warnings[0];
        EXPECT_NE(warnings[0].find("rejected"), std::string::npos) << warnings[0];
        for (std::size_t i = 0; i < clean.values.size(); ++i) {
            EXPECT_EQ(again.values[i].term, clean.values[i].term) << term << " point " << i;
            EXPECT_EQ(again.values[i].std_error, clean.values[i].std_error) << term << " point " << i;
        }
    }
    EXPECT_GE(std::distance(fs::directory_iterator(path("cache/rejected")), fs::directory_iterator{}), 2);
    // With no backend to recompute, the damaged file is named.
    rewrite_term(file, 3, "0.5");
    ms::design::CacheConfig none = config;
    none.backend = nullptr;
    try {
        ms::design::load_or_compute(def, none);
        ADD_FAILURE() << "a changed cache file was read";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
}

TEST_F(DesignReliability, ChangedChunksAreSetAsideAndRecomputedOnResume) {
    auto backend = ms::make_oracle_backend(2);
    const auto def = small_reliability_definition();
    ms::design::CacheConfig config;
    config.dir = path("cache");
    config.backend = backend.get();
    config.chunk_points = 16;
    config.max_chunks = 2;
    EXPECT_THROW(ms::design::load_or_compute(def, config), ms::design::IncompleteReference);
    const std::string chunks = fs::path(ms::design::cache_file(def, config.dir)).replace_extension(".chunks").string();
    rewrite_term(chunks + "/chunk-000000.csv", 2, "0.25");   // a plausible value
    rewrite_term(chunks + "/chunk-000001.csv", 0, "-0.01");  // outside [0, 1]
    std::vector<std::string> warnings;
    config.max_chunks = 0;
    config.warn = [&](const std::string& w) { warnings.push_back(w); };
    ms::design::CacheReport report;
    const auto resumed = ms::design::load_or_compute(def, config, &report);
    EXPECT_EQ(report.chunks_found, 0u);
    EXPECT_EQ(report.chunks_computed, 3u);
    EXPECT_EQ(warnings.size(), 2u);
    ms::design::CacheConfig fresh = config;
    fresh.dir = path("fresh");
    const auto whole = ms::design::load_or_compute(def, fresh);
    for (std::size_t i = 0; i < whole.values.size(); ++i) EXPECT_EQ(whole.values[i].term, resumed.values[i].term) << i;
}

TEST_F(DesignReliability, ASecondRunOnTheSameCacheWaitsForTheFirstAndReadsItsSet) {
    auto backend_a = ms::make_oracle_backend(1);
    auto backend_b = ms::make_oracle_backend(1);
    const auto def = small_reliability_definition();
    // Run A is held inside its computation (in its progress callback) until run B has shown that it
    // waits; without a lock B would compute the same chunks and A's cleanup would remove them.
    std::mutex m;
    std::condition_variable cv;
    bool a_started = false, b_waiting = false;
    ms::design::CacheConfig a;
    a.dir = path("cache");
    a.backend = backend_a.get();
    a.chunk_points = 16;
    a.progress = [&](std::size_t, std::size_t) {
        std::unique_lock<std::mutex> lock(m);
        a_started = true;
        cv.notify_all();
        cv.wait_for(lock, std::chrono::seconds(20), [&] { return b_waiting; });
    };
    ms::design::CacheConfig b = a;
    b.backend = backend_b.get();
    b.progress = {};
    b.warn = [&](const std::string& w) {
        if (w.find("waiting") == std::string::npos) return;
        std::lock_guard<std::mutex> lock(m);
        b_waiting = true;
        cv.notify_all();
    };
    ms::design::CacheReport report_a, report_b;
    auto run_a = std::async(std::launch::async, [&] { return ms::design::load_or_compute(def, a, &report_a); });
    {
        std::unique_lock<std::mutex> lock(m);
        ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(20), [&] { return a_started; }));
    }
    auto run_b = std::async(std::launch::async, [&] { return ms::design::load_or_compute(def, b, &report_b); });
    const auto set_a = run_a.get();
    const auto set_b = run_b.get();
    EXPECT_TRUE(b_waiting) << "run B did not wait for run A";
    EXPECT_TRUE(report_b.from_cache) << "run B should have read A's finished set";
    EXPECT_EQ(report_a.chunks_computed, 3u);
    ASSERT_EQ(set_a.values.size(), set_b.values.size());
    for (std::size_t i = 0; i < set_a.values.size(); ++i) EXPECT_EQ(set_a.values[i].term, set_b.values[i].term) << i;
    EXPECT_FALSE(fs::exists(fs::path(set_a.file).replace_extension(".chunks")));
}

// ---------------------------------------------------------------------------------------------------
// design's command line: everything refused before any work.

// A small points CSV and reference spec; `sampling` is the spec's [sampling] table body.
void write_reference(const fs::path& dir, const std::string& name, const std::string& sampling) {
    std::ofstream f(dir / "points.csv");
    f << "visibility,n_dot_l,n_dot_v,roughness,relative_azimuth_deg,weight\n";
    for (int i = 0; i < 24; ++i)
        f << 0.55 + 0.4 * ((i * 7) % 24) / 23.0 << "," << 0.1 + 0.85 * ((i * 5) % 24) / 23.0 << "," << 0.3 + 0.6 * (i % 4) / 3.0
          << ",0.4,0,1\n";
    std::ofstream s(dir / name);
    s << "[points]\ncsv = \"points.csv\"\n[sampling]\n" << sampling;
}

bool folder_is_empty_or_absent(const fs::path& p) { return !fs::exists(p) || fs::is_empty(p); }

TEST_F(DesignReliability, BadSamplingBadNamesAndMalformedBudgetsAreRefusedBeforeAnyWork) {
    write_reference(dir_, "ref.toml", "method = \"sampled\"\nsamples = 1024\n");
    // A fit reference whose point set cannot be held (2^31 points per replicate): refused before the
    // evaluation set is computed, not after.
    write_reference(dir_, "huge.toml", "method = \"sampled\"\nsamples = 4294967296\nreplicates = 2\n");
    const ChildRun huge = cli("design -q --backend oracle --reference ref.toml --fit-reference huge.toml --cache cache --out out");
    EXPECT_EQ(huge.exit_code, 2) << huge.log;
    EXPECT_NE(huge.log.find("huge.toml"), std::string::npos) << huge.log;
    EXPECT_TRUE(folder_is_empty_or_absent(dir_ / "cache")) << "work was done before the refusal";
    // Samples below 16 a replicate are rounded up as every sampling command rounds them (they used to fail
    // after the work and leave a chunks folder behind).
    write_reference(dir_, "few.toml", "method = \"sampled\"\nsamples = 64\nreplicates = 8\n");
    const ChildRun few = cli("design -q --backend oracle --reference few.toml --cache cache");
    EXPECT_EQ(few.exit_code, 0) << few.log;
    for (const auto& e : fs::directory_iterator(dir_ / "cache"))
        EXPECT_NE(e.path().extension(), ".chunks") << "left behind: " << e.path();

    // Names that would break the CSV or Markdown rows or the chosen file's name.
    ASSERT_EQ(cli("bake -q --layout custom --size 4 --roughness 0.4 --samples 1024 --out lut.exr").exit_code, 0);
    fs::copy_file(dir_ / "lut.exr", dir_ / "a,b.exr");
    for (const std::string& arg : {std::string("'x,y=lut.exr'"), std::string("'x\"y=lut.exr'"), std::string("\"$(printf 'x\\ny')=lut.exr\""),
                                   std::string("a,b.exr"), std::string("'../up=lut.exr'"), std::string("'-dash=lut.exr'")}) {
        const ChildRun r = cli("design -q --backend oracle --reference ref.toml --cache cache2 --out bad --lut " + arg);
        EXPECT_EQ(r.exit_code, 2) << arg << "\n" << r.log;
        EXPECT_NE(r.log.find("candidate name"), std::string::npos) << arg << "\n" << r.log;
        EXPECT_TRUE(folder_is_empty_or_absent(dir_ / "cache2")) << arg;
        EXPECT_FALSE(fs::exists(dir_ / "bad" / "pareto.csv")) << arg;
    }
    // An unknown --choose is known before the work too.
    const ChildRun choose = cli("design -q --backend oracle --reference ref.toml --cache cache3 --choose nothing");
    EXPECT_EQ(choose.exit_code, 2) << choose.log;
    EXPECT_TRUE(folder_is_empty_or_absent(dir_ / "cache3"));
    // Budgets are decimal sizes.
    for (const char* bytes : {"0x10", " 5", "1e3", "inf", "nan", "5.", ".5", "-0", "1.5 MiB", "12XB"}) {
        const ChildRun r = cli(std::string("design -q --backend oracle --reference ref.toml --cache cache4 --max-bytes '") + bytes + "'");
        EXPECT_EQ(r.exit_code, 2) << bytes << "\n" << r.log;
        EXPECT_NE(r.log.find("--max-bytes"), std::string::npos) << bytes << "\n" << r.log;
        EXPECT_TRUE(folder_is_empty_or_absent(dir_ / "cache4")) << bytes;
    }
    const ChildRun ok = cli("design -q --backend oracle --reference ref.toml --cache cache --max-bytes 1.5KiB --lut good=lut.exr --out ok");
    EXPECT_EQ(ok.exit_code, 0) << ok.log;
}

TEST_F(DesignReliability, CandidateNamesAreCheckedAndTheTablesEscapeWhatTheyQuote) {
    for (const char* good : {"lut-16", "closed-form-3", "a.b_c+d", "X"}) EXPECT_NO_THROW(ms::design::check_candidate_name(good)) << good;
    for (const char* bad : {"", ".hidden", "-x", "a,b", "a\"b", "a\nb", "a|b", "a/b", "a b"})
        EXPECT_THROW(ms::design::check_candidate_name(bad), std::invalid_argument) << bad;
    EXPECT_THROW(ms::design::check_candidate_name(std::string(65, 'a')), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------------
// Representation files.

// Rewrites a representation EXR with its texels changed by `edit` and its metadata by `edit_meta`.
void rewrite_representation(const std::string& from, const std::string& to,
                            const std::function<void(std::vector<float>&, std::size_t channels)>& edit,
                            const std::function<void(nlohmann::json&)>& edit_meta) {
    Imf::InputFile in(from.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    const std::uint32_t w = std::uint32_t(dw.max.x - dw.min.x + 1), h = std::uint32_t(dw.max.y - dw.min.y + 1);
    std::vector<std::string> names;
    for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) names.push_back(it.name());
    std::vector<float> data(std::size_t(w) * h * names.size());
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < names.size(); ++c)
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(data.data() + c), names.size() * sizeof(float),
                                       names.size() * sizeof(float) * w));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    nlohmann::json meta = nlohmann::json::parse(in.header().typedAttribute<Imf::StringAttribute>("microshadow").value());
    edit(data, names.size());
    edit_meta(meta);
    // Channels the edited metadata names that the file lacks are added (zeros); OpenEXR sorts them.
    std::vector<std::string> unique = names;
    for (const auto& n : meta["texture"]["channels"])
        if (std::find(unique.begin(), unique.end(), n.get<std::string>()) == unique.end()) unique.push_back(n.get<std::string>());
    std::sort(unique.begin(), unique.end());
    std::vector<float> unique_data(std::size_t(w) * h * unique.size(), 0.0f);
    for (std::size_t p = 0; p < std::size_t(w) * h; ++p)
        for (std::size_t c = 0; c < unique.size(); ++c) {
            const std::size_t src = std::size_t(std::find(names.begin(), names.end(), unique[c]) - names.begin());
            if (src < names.size()) unique_data[p * unique.size() + c] = data[p * names.size() + src];
        }
    Imf::Header header = ms::exr::image_header(w, h, unique, false);
    header.insert("microshadow", Imf::StringAttribute(meta.dump()));
    ms::exr::write_interleaved(to, header, unique, unique_data, unique.size(), false);
}

void expect_refused(const std::string& file, const std::string& words) {
    try {
        ms::repr::open_representation(file);
        ADD_FAILURE() << file << " was accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
}

TEST_F(DesignReliability, RepresentationFilesWithTexelsOutOfRangeOrWrongChannelsAreRefused) {
    ASSERT_EQ(cli("repr bake -q --kind azimuth-axis --visibility-count 4 --n-dot-l-count 4 --n-dot-v-count 2 --azimuth-nodes 3 "
                  "--roughness 0.3,0.7 --samples 1024 --out axis.exr")
                  .exit_code,
              0);
    ASSERT_EQ(cli("repr bake -q --kind azimuth-harmonics --visibility-count 4 --n-dot-l-count 4 --n-dot-v-count 2 "
                  "--azimuth-nodes 7 --roughness 0.3,0.7 --samples 1024 --out harm.exr")
                  .exit_code,
              0);
    const std::string axis = path("axis.exr"), harm = path("harm.exr");
    // Rewritten unchanged: still accepted (the rewriting itself is sound).
    rewrite_representation(axis, path("same.exr"), [](auto&, std::size_t) {}, [](auto&) {});
    EXPECT_NO_THROW(ms::repr::open_representation(path("same.exr")));
    // A term above 1, and below 0.
    rewrite_representation(axis, path("high.exr"), [](auto& d, std::size_t) { d[5] = 1.5f; }, [](auto&) {});
    expect_refused(path("high.exr"), "outside [0.0, 1.0]");
    rewrite_representation(axis, path("low.exr"), [](auto& d, std::size_t) { d[0] = -0.25f; }, [](auto&) {});
    expect_refused(path("low.exr"), "outside");
    // Harmonics: a0 is a mean of terms, a1..a3 within +-2.
    rewrite_representation(harm, path("a1ok.exr"), [](auto& d, std::size_t n) { d[1 % n] = 1.9f; }, [](auto&) {});
    EXPECT_NO_THROW(ms::repr::open_representation(path("a1ok.exr")));
    rewrite_representation(harm, path("a0bad.exr"),
                           [](auto& d, std::size_t n) { d[n * 3 + 0] = 1.01f; },  // cos0phi sorts first
                           [](auto&) {});
    expect_refused(path("a0bad.exr"), "channel cos0phi");
    rewrite_representation(harm, path("a3bad.exr"), [](auto& d, std::size_t n) { d[n * 2 + 3] = -2.5f; }, [](auto&) {});
    expect_refused(path("a3bad.exr"), "outside [-2.0, 2.0]");
    // Channels: one named twice, one missing, or not the grid's names.
    rewrite_representation(axis, path("twice.exr"), [](auto&, std::size_t) {}, [](nlohmann::json& m) {
        auto& c = m["texture"]["channels"];
        c[1] = c[0];
    });
    expect_refused(path("twice.exr"), "twice");
    rewrite_representation(axis, path("missing.exr"), [](auto&, std::size_t) {}, [](nlohmann::json& m) {
        m["texture"]["channels"].erase(1);
    });
    expect_refused(path("missing.exr"), "are not the channels");
    rewrite_representation(harm, path("renamed.exr"), [](auto&, std::size_t) {}, [](nlohmann::json& m) {
        m["texture"]["channels"] = {"R", "G", "B", "A"};
    });
    expect_refused(path("renamed.exr"), "are not the channels");
    // Through the commands: bad input, exit status 2, the file named.
    const ChildRun info = cli("repr info high.exr");
    EXPECT_EQ(info.exit_code, 2) << info.log;
    EXPECT_NE(info.log.find("high.exr"), std::string::npos) << info.log;
    // KTX2 files are checked the same way (export, then flip one texel's bits to a value above 1).
    ASSERT_EQ(cli("repr export axis.exr --out axis.ktx2").exit_code, 0);
    EXPECT_NO_THROW(ms::repr::open_representation(path("axis.ktx2")));
    std::string k = slurp_file(path("axis.ktx2"));
    const float big = 3.0f;
    std::memcpy(&k[k.size() - 4], &big, 4);  // the last texel's alpha (float32 export)
    std::ofstream(path("bad.ktx2"), std::ios::binary) << k;
    expect_refused(path("bad.ktx2"), "outside");
}

// ---------------------------------------------------------------------------------------------------
// Sweep comparator files.

TEST_F(DesignReliability, SweepNamesAMissingOrDamagedComparatorBeforeStarting) {
    ASSERT_EQ(cli("bake -q --layout custom --size 4 --roughness 0.4 --samples 1024 --out lut.exr").exit_code, 0);
    const std::string whole = slurp_file(path("lut.exr"));
    std::ofstream(path("half.exr"), std::ios::binary) << whole.substr(0, whole.size() / 2);
    for (const char* file : {"gone.exr", "half.exr"}) {
        std::ofstream(path("s.toml"), std::ios::trunc)
            << "[parameters]\nvisibility = [0.5, 0.9]\nn_dot_l = [0.5]\nroughness = [0.4]\nn_dot_v = [0.7]\n"
            << "[comparators]\nanalytic = [\"reference-step\"]\n[[comparators.lut]]\nname = \"mine\"\nfile = \"" << file << "\"\n";
        const ChildRun r = cli("sweep s.toml --out out -q --method sampled --samples 1024");
        EXPECT_EQ(r.exit_code, 2) << file << "\n" << r.log;
        EXPECT_NE(r.log.find("comparators.lut[0] 'mine'"), std::string::npos) << file << "\n" << r.log;
        EXPECT_NE(r.log.find(file), std::string::npos) << r.log;
        EXPECT_FALSE(fs::exists(dir_ / "out")) << "the sweep started before the refusal";
    }
}

// ---------------------------------------------------------------------------------------------------
// Device failure and SIGTERM, job by job.

struct Job {
    std::string args;                                    // writes to OUT (a folder or a file stem)
    std::string output;                                  // the file that appears last, OUT replaced
    std::function<std::string(const fs::path&)> result;  // OUT's bits that must not depend on the run
};

// Each job sized so that its work is at least two items of the scheduler (an item is about 2^28
// samples), so that both devices take one: a few tenths of a second of computing.
Job job_named(const std::string& name, const fs::path& dir) {
    if (name == "eval") {
        std::ofstream q(dir / "q.csv");
        q << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n";
        std::mt19937 rng(3);
        std::uniform_real_distribution<double> u(0.05, 0.95);
        for (int i = 0; i < 128; ++i)  // 2 items of 64 queries at 2^22 samples
            q << 0.5 + 0.45 * u(rng) << "," << u(rng) << "," << u(rng) << "," << u(rng) << ",0.1," << u(rng) << "," << u(rng)
              << ",0.2," << u(rng) << "\n";
        return {"eval --method sampled --in q.csv --out OUT.csv --samples 4194304 --seed 3", "OUT.csv",
                [](const fs::path& f) { return slurp_file(f.string() + ".csv"); }};
    }
    if (name == "bake")  // 16 slices
        return {"bake --layout seed-3d --size 4 --samples 16384 --seed 5 --out OUT.exr", "OUT.exr", [](const fs::path& f) {
                    const auto l = ms::read_lut(f.string() + ".exr");
                    return std::string(reinterpret_cast<const char*>(l.data.data()), l.data.size() * sizeof(float));
                }};
    if (name == "sweep") {  // 4 chunks
        std::ofstream s(dir / "s.toml");
        s << "[sweep]\nchunk_size = 16\n[parameters]\nvisibility = { start = 0.5, stop = 1.0, count = 8 }\n"
          << "n_dot_l = { start = 0.1, stop = 1.0, count = 8 }\nroughness = [0.4]\nn_dot_v = [0.6]\n"
          << "[comparators]\nanalytic = [\"reference-step\"]\n";
        return {"sweep s.toml --out OUT --method sampled --samples 65536 --seed 9", "OUT/sweep.csv",
                [](const fs::path& f) { return slurp_file(f / "sweep.csv"); }};
    }
    if (name == "repr-bake")  // 768 texel x node queries at 2^20 samples: 3 items
        return {"repr bake --kind azimuth-axis --visibility-count 4 --n-dot-l-count 4 --n-dot-v-count 4 --azimuth-nodes 3 "
                "--method sampled --samples 1048576 --out OUT.exr",
                "OUT.exr", [](const fs::path& f) {
                    const auto r = ms::repr::open_representation(f.string() + ".exr");
                    return std::string(reinterpret_cast<const char*>(r->texels().data()), r->texels().size() * sizeof(float));
                }};
    // design: 24 reference points at 2^24 samples, 16 queries an item: 2 items.
    write_reference(dir, "ref.toml", "method = \"sampled\"\nsamples = 16777216\n");
    return {"design --reference ref.toml --cache OUT.cache --out OUT", "OUT/pareto.csv", [](const fs::path& f) {
                std::string bits = slurp_file(f / "pareto.csv");
                for (const auto& e : fs::directory_iterator(f.string() + ".cache"))
                    if (e.path().extension() == ".csv") bits += slurp_file(e.path());
                return bits;
            }};
}

std::string with_out(std::string args, const std::string& out) {
    for (std::size_t p; (p = args.find("OUT")) != std::string::npos;) args.replace(p, 3, out);
    return args;
}

// Temporaries of an atomic write, anywhere under `dir` (".NAME.tmp.PID" and the like).
std::vector<std::string> temporaries(const fs::path& dir) {
    std::vector<std::string> found;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name.find(".tmp.") != std::string::npos || name.find(".bak.") != std::string::npos) found.push_back(e.path().string());
    }
    return found;
}

class JobFaults : public ms::testing::ScratchDirTest, public ::testing::WithParamInterface<std::string> {
protected:
    JobFaults() : ScratchDirTest("job_faults") {}
};

TEST_P(JobFaults, AFailingDeviceOrASigtermChangesNoBitAndLeavesNoTemporary) {
    const Job job = job_named(GetParam(), dir_);
    const ChildRun clean = run_microshadow(dir_, with_out(job.args, "clean") + " -q");
    ASSERT_EQ(clean.exit_code, 0) << clean.log;
    const std::string expected = job.result(dir_ / "clean");

    // Two devices, device 0 failing at its first item: its work moves to device 1, the bits stay.
    const ChildRun failing = run_microshadow(dir_, with_out(job.args, "two") + " -q --device all",
                                             "POCL_DEVICES='pthread pthread' MICROSHADOW_FAIL_DEVICE=0:0");
    ASSERT_EQ(failing.exit_code, 0) << failing.log;
    EXPECT_EQ(job.result(dir_ / "two"), expected);
    // The same fault with no other device: the job fails cleanly, writing nothing (and so the fault
    // does reach this job).
    const ChildRun dead = run_microshadow(dir_, with_out(job.args, "dead") + " -q --device 0", "MICROSHADOW_FAIL_DEVICE=0:0");
    EXPECT_EQ(dead.exit_code, 1) << dead.log;
    EXPECT_FALSE(fs::exists(dir_ / with_out(job.output, "dead")));

    // SIGTERM somewhere in the second half of a run (computing or writing), then the same command.
    const std::string args = with_out(job.args, "stopped") + " -q";
    const pid_t pid = ms::testing::spawn_microshadow(dir_, args);
    std::mt19937 rng(std::hash<std::string>()(GetParam()));
    std::this_thread::sleep_for(std::chrono::duration<double>(std::uniform_real_distribution<double>(0.5, 0.9)(rng) * clean.seconds));
    kill(pid, SIGTERM);
    const int code = ms::testing::wait_for_exit(pid);
    EXPECT_TRUE(code == 143 || code == 0) << "exit " << code << "\n" << slurp_file(dir_ / "log.txt");
    if (code == 143) EXPECT_FALSE(fs::exists(dir_ / with_out(job.output, "stopped"))) << "an interrupted run wrote its output";
    EXPECT_TRUE(temporaries(dir_).empty());
    const ChildRun rerun = run_microshadow(dir_, args);
    ASSERT_EQ(rerun.exit_code, 0) << rerun.log;
    EXPECT_EQ(job.result(dir_ / "stopped"), expected) << "the rerun differs from the clean run";
    EXPECT_TRUE(temporaries(dir_).empty());
    std::printf("[job faults] %s: clean run %.2f s, SIGTERM exit %d\n", GetParam().c_str(), clean.seconds, code);
}

INSTANTIATE_TEST_SUITE_P(Jobs, JobFaults, ::testing::Values("eval", "bake", "sweep", "repr-bake", "design"),
                         [](const ::testing::TestParamInfo<std::string>& p) {
                             std::string n = p.param;
                             std::replace(n.begin(), n.end(), '-', '_');
                             return n;
                         });

}  // namespace
