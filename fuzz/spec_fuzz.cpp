// libFuzzer target: the TOML sweep specification reader (ms::sweep::parse_spec).
// Contract: a spec is accepted (and then its grid is bounded by max_points, its canonical text can be
// produced, its roughness lies in (0, 1] and its column names hold no control characters) or rejected
// with ms::sweep::SpecError; anything else is a finding. Until host/jobs/sweep/
// spec.cpp exists the target exercises toml++ itself, the parser the spec reader is built on.
#include <cstdint>
#include <string>

#include "fuzz_common.hpp"

#ifdef MICROSHADOW_HAVE_SWEEP_SPEC
#include "jobs/sweep/spec.hpp"
#else
#include <toml++/toml.h>
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
#ifdef MICROSHADOW_HAVE_SWEEP_SPEC
    try {
        // A base directory that does not exist: LUT comparators must be resolved lazily or rejected
        // with a SpecError, never opened relative to the fuzzer's working directory.
        const ms::sweep::Spec spec = ms::sweep::parse_spec(text, "fuzz.toml", "/nonexistent-microshadow-fuzz");
        if (spec.max_points > ms::sweep::kHardMaxPoints) ms::fuzz::finding("max_points above the hard ceiling accepted");
        if (spec.visibility.empty() || spec.n_dot_l.empty()) ms::fuzz::finding("required axis accepted empty");
        (void)ms::sweep::canonical_text(spec);
        (void)ms::sweep::comparator_names(spec);
        // What the spec accepts, a run must be able to compute.
        for (double r : spec.roughness)
            if (!(r > 0 && r <= 1 && r * r > 0)) ms::fuzz::finding("roughness outside (0, 1] (or alpha underflowing) accepted");
        for (const auto& l : spec.luts)
            for (unsigned char c : l.name)
                if (c < 0x20 || c == 0x7F) ms::fuzz::finding("control character in a LUT column name accepted");
    } catch (const ms::sweep::SpecError&) {
    }
#else
    try {
        const toml::table table = toml::parse(text, "fuzz.toml");
        (void)table.size();
    } catch (const toml::parse_error&) {
    }
#endif
    return 0;
}
