// JSON read from files a user hands the tool (LUT and representation metadata: a KTX2 key/value
// entry, a DDS sidecar, an EXR attribute, a PNG text chunk, a C header's string; chunk-store
// manifests). nlohmann::json builds and destroys nested values recursively: a 200 KB text of 100,000
// nested brackets overflows the stack (SIGSEGV) in parse, dump or the destructor. The rule: the text's
// size and nesting depth are checked by a linear scan before the parser sees it.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <stdexcept>
#include <string>

namespace ms {

// Deepest nesting of arrays and objects the tool's own metadata never comes near (it nests 4 deep).
inline constexpr std::size_t kMaxJsonDepth = 64;
// Largest metadata text (the tool writes a few KiB; a partial bake's coverage record reaches ~1 MiB).
inline constexpr std::size_t kMaxJsonBytes = std::size_t(16) << 20;

class JsonLimitError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// The nesting depth of `text` read as JSON (brackets inside strings do not count; no validation).
std::size_t json_nesting_depth(const std::string& text);

// `text` parsed; `what` names it in messages ("the \"microshadow\" key/value entry"). Throws
// JsonLimitError when it is longer than max_bytes or nests deeper than max_depth, std::runtime_error
// ("WHAT is not JSON") when it does not parse.
nlohmann::json parse_bounded_json(const std::string& text, const std::string& what, std::size_t max_depth = kMaxJsonDepth,
                                  std::size_t max_bytes = kMaxJsonBytes);

}  // namespace ms
