// libFuzzer target: the text helpers that keep JSON provenance and recorded command lines valid
// whatever bytes a file name or argument holds (host/io/text.hpp).
// Contract: json_safe() returns valid UTF-8, is the identity on valid UTF-8, and never shrinks its
// input; dump_json() never throws; shell_quote() returns valid UTF-8 that is one shell word.
#include <cstdint>
#include <string>

#include "fuzz_common.hpp"
#include "io/text.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string in(reinterpret_cast<const char*>(data), size);
    const std::string safe = ms::json_safe(in);
    if (!ms::is_valid_utf8(safe)) ms::fuzz::finding("json_safe returned invalid UTF-8");
    if (ms::is_valid_utf8(in) && safe != in) ms::fuzz::finding("json_safe changed valid UTF-8");
    if (safe.size() < in.size()) ms::fuzz::finding("json_safe dropped bytes");
    try {
        (void)ms::dump_json(nlohmann::json{{"raw", in}, {"safe", safe}}, 1);
        // A string that went through json_safe dumps with the strict (throwing) handler as well.
        (void)nlohmann::json(safe).dump();
    } catch (const nlohmann::json::exception&) {
        ms::fuzz::finding("JSON dump threw");
    }
    const std::string quoted = ms::shell_quote(in);
    if (!ms::is_valid_utf8(quoted)) ms::fuzz::finding("shell_quote returned invalid UTF-8");
    if (quoted.empty()) ms::fuzz::finding("shell_quote returned an empty word");
    return 0;
}
