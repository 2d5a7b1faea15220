// libFuzzer target: the files a sweep resumes from. The first input byte picks the file the rest
// replaces in a stopped sweep's item store (items 0 and 1 of 3 finished): 0..63 the rows of item 1
// under its old seal, 64..127 the rows of item 1 sealed again (size and FNV-1a 64 recomputed: a forged
// item, since anyone can recompute a digest, so only the checks of the rows' values stand between it
// and sweep.csv), 128..191 the store's manifest, 192..255 sweep-spec.json. Contract: run_sweep either
// assembles exactly the sweep.csv of a clean run (a damaged item is set aside and computed again) - for
// a forged item, a sweep.csv whose every term is a fraction in [0, 1] with a standard error in [0, 1] -
// or refuses with std::invalid_argument / std::runtime_error naming a file; it never crashes, never
// hangs, and never assembles other bytes.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>


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
        "[sweep]\nchunk_size = 4\n[parameters]\nvisibility = [0.3, 0.7]\nn_dot_l = [0.5, 0.7, 0.9]\nroughness = [0.4, 0.8]\n",
        "fuzz.toml");
    std::unique_ptr<ms::TermBackend> backend = ms::make_oracle_backend(1);
    fs::path root = fs::path(ms::fuzz::scratch_path("_sweep"));
    fs::path state = root / "state";  // a sweep stopped before assembling: items 0 and 1 of 3, the manifest
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
        c.max_chunks = 2;  // two of the three chunks finished, not yet assembled
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
    const bool forged = data[0] >= 64 && data[0] < 128;
    const std::string input(reinterpret_cast<const char*>(data + 1), size - 1);
    if (data[0] < 128) {
        // An item: five header lines (magic, spec hash, id, payload size, FNV-1a 64), then the rows.
        const fs::path item = dir / "items" / "item-0000000001.bin";
        const std::string old = slurp(item);
        std::size_t rows_at = 0;
        for (int line = 0; line < 5; ++line) rows_at = old.find('\n', rows_at) + 1;
        std::string header = old.substr(0, rows_at);
        if (forged) {
            std::size_t at = 0;
            for (int line = 0; line < 3; ++line) at = header.find('\n', at) + 1;
            header = header.substr(0, at) + std::to_string(input.size()) + "\n" + ms::hex16(ms::fnv1a(input)) + "\n";
        }
        const std::string bytes = header + input;
        ms::fuzz::write_scratch(item.string(), reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    } else {
        const fs::path target = data[0] < 192 ? dir / "manifest.shard-0-of-1.json" : dir / "sweep-spec.json";
        ms::fuzz::write_scratch(target.string(), data + 1, size - 1);
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
