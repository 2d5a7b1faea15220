// libFuzzer target: the files a sweep resumes from. The first input byte picks the
// file the rest replaces in a finished, unassembled sweep directory: 0..63 chunk 1, 64..127 chunk 1
// with its digest in the manifest recomputed (a forged chunk: anyone can recompute a digest, so only
// the checks of the rows' values stand between it and sweep.csv), 128..255 the manifest. Contract:
// run_sweep either assembles exactly the sweep.csv of a clean run (a damaged chunk is set aside and
// computed again) - for a forged chunk, a sweep.csv whose every term is a fraction in [0, 1] with a
// standard error in [0, 1] - or refuses with std::invalid_argument / std::runtime_error naming a file;
// it never crashes, never hangs, and never assembles other bytes.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "core/digest.hpp"
#include "fuzz_common.hpp"
#include "jobs/eval.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

struct Fixture {
    ms::sweep::Spec spec = ms::sweep::parse_spec(
        "[sweep]\nchunk_size = 4\n[parameters]\nvisibility = [0.3, 0.7]\nn_dot_l = [0.5, 0.9]\nroughness = [0.4, 0.8]\n",
        "fuzz.toml");
    std::unique_ptr<ms::TermBackend> backend = ms::make_oracle_backend(1);
    fs::path root = fs::path(ms::fuzz::scratch_path("_sweep"));
    fs::path state = root / "state";  // a sweep stopped before assembling: both chunks and the manifest
    std::string clean_csv;

    ms::sweep::RunConfig config(const fs::path& dir) const {
        ms::sweep::RunConfig c;
        c.out_dir = dir.string();
        c.plan.samples = 64;
        c.plan.replicates = 4;
        c.backend = backend.get();
        return c;
    }
    Fixture() {
        fs::remove_all(root);
        ms::sweep::run_sweep(spec, config(root / "clean"));
        clean_csv = slurp(root / "clean" / "sweep.csv");
        ms::sweep::RunConfig c = config(state);
        c.max_chunks = 2;  // both chunks finished, not yet assembled
        ms::sweep::run_sweep(spec, c);
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static Fixture f;
    if (size == 0) return 0;
    const fs::path dir = f.root / "run";
    fs::remove_all(dir);
    fs::copy(f.state, dir, fs::copy_options::recursive);
    const fs::path target = data[0] < 128 ? dir / "chunks" / "chunk-0000000001.csv" : dir / "manifest.json";
    ms::fuzz::write_scratch(target.string(), data + 1, size - 1);
    const bool forged = data[0] >= 64 && data[0] < 128;
    if (forged) {
        // The manifest's record of chunk 1 made to match the new bytes (rows and FNV-1a 64).
        nlohmann::json m = nlohmann::json::parse(slurp(dir / "manifest.json"));
        const std::string text = slurp(target);
        std::uint64_t rows = 0;
        for (char c : text) rows += c == '\n';
        m["digests"]["1"] = {{"rows", rows}, {"fnv1a64", ms::hex16(ms::fnv1a(text))}};
        std::ofstream(dir / "manifest.json", std::ios::binary | std::ios::trunc) << m.dump();
    }
    try {
        const ms::sweep::RunResult r = ms::sweep::run_sweep(f.spec, f.config(dir));
        if (!r.assembled) ms::fuzz::finding("a resumed two-chunk sweep did not finish");
        const std::string csv = slurp(dir / "sweep.csv");
        if (!forged && csv != f.clean_csv) ms::fuzz::finding("a damaged file changed the assembled sweep.csv");
        if (forged) {
            // Every row's term (field 13) and std_error (field 14) as the chunk check promises.
            std::istringstream rows(csv);
            std::string line;
            std::getline(rows, line);  // the header
            while (std::getline(rows, line)) {
                std::istringstream fields(line);
                std::string field;
                for (int k = 0; k < 12; ++k) std::getline(fields, field, ',');
                std::string term, error;
                std::getline(fields, term, ',');
                std::getline(fields, error, ',');
                const double t = std::strtod(term.c_str(), nullptr), e = std::strtod(error.c_str(), nullptr);
                if (!(t >= 0 && t <= 1) || !(e >= 0 && e <= 1)) ms::fuzz::finding("a forged chunk put a term or std_error out of range into sweep.csv");
            }
        }
    } catch (const std::invalid_argument&) {
    } catch (const std::runtime_error&) {
    }
    return 0;
}
