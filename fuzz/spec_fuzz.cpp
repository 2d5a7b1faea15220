// libFuzzer target: the TOML sweep specification reader (ms::sweep::parse_spec, issue 4).
// Contract: a spec is accepted (and then its grid is bounded by max_points and its canonical text can
// be produced) or rejected with ms::sweep::SpecError; anything else is a finding. Until host/jobs/sweep/
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
