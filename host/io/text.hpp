// Text that goes into JSON provenance and into messages. nlohmann::json refuses to dump a string
// that is not valid UTF-8 (type_error 316), and Linux file names and arguments are bytes, not UTF-8:
// `bake --out $'lut\xe9.exr'` baked to 100 % and then failed writing its metadata. The rule of this
// project: invalid bytes are escaped, never rejected (a Latin-1 file name is a legal name) -
//   - json_safe(s): s with every byte that is not part of valid UTF-8 written as the text \xHH;
//   - dump_json(j, indent): j.dump() that escapes the same way (as U+FFFD, nlohmann's replace mode)
//     instead of throwing, for any string that did not go through json_safe;
//   - shell_quote(arg): one argument as a bash word that reproduces the same bytes ($'...' with \xHH
//     for invalid or control bytes), valid UTF-8 itself: the recorded command line can be pasted back.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace ms {

bool is_valid_utf8(std::string_view s);
// Length of the valid UTF-8 sequence starting at s[i] (1 for ASCII), or 0 when none starts there.
std::size_t utf8_length_at(std::string_view s, std::size_t i);
std::string json_safe(std::string_view s);
std::string dump_json(const nlohmann::json& j, int indent = -1);
std::string shell_quote(std::string_view arg);

// Levenshtein distance (single-character edits between two words), for "did you mean" suggestions.
std::size_t edit_distance(const std::string& a, const std::string& b);

// v in printf's %g with `digits` significant digits (3 for messages and labels, 9 to round-trip a float).
std::string format_g(double v, int digits = 3);
// s with its ASCII letters in upper case (labels, C identifiers).
std::string to_upper(std::string s);

}  // namespace ms
