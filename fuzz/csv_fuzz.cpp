// libFuzzer target: the strict numeric CSV reader and the query reader of `microshadow eval`.
// Contract under test: every input either yields rows of finite numbers (and, for queries, queries the
// evaluator accepts) or throws ms::CsvError; any other exception, a crash, a sanitizer report, a hang
// or unbounded allocation is a finding.
#include <cmath>
#include <cstdint>

#include "jobs/eval.hpp"
#include "fuzz_common.hpp"
#include "io/csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string& path = ms::fuzz::scratch_path(".csv");
    ms::fuzz::write_scratch(path, data, size);

    // A small column set, so the fuzzer reaches the row parser with short inputs as well.
    // An accepted file is text with LF or CRLF line ends: no NUL, no control byte other than
    // tab, no CR without LF (a CR-only file read as one line and reported "duplicate column").
    auto is_clean_text = [&] {
        for (std::size_t i = 0; i < size; ++i) {
            const unsigned char c = data[i];
            if (c == '\r' && i + 1 < size && data[i + 1] != '\n') return false;
            if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7F) return false;
        }
        return true;
    };
    try {
        const ms::NumericCsv t = ms::read_numeric_csv(path, {"a", "b"});
        if (!is_clean_text()) ms::fuzz::finding("a file with NUL, control bytes or CR-only line ends accepted");
        if (t.rows.size() != t.lines.size()) ms::fuzz::finding("rows and line numbers disagree");
        for (const auto& row : t.rows) {
            if (row.size() != 2) ms::fuzz::finding("row width differs from the expected columns");
            for (double v : row)
                if (!std::isfinite(v)) ms::fuzz::finding("non-finite value accepted");
        }
    } catch (const ms::CsvError&) {
    }

    try {
        for (const ms::Query& q : ms::read_query_csv(path)) {
            // What the reader accepts, the evaluator must accept too (else eval fails late, after
            // the device was set up, with a message that names no line).
            try {
                ms::validate_query(q);
            } catch (const std::invalid_argument&) {
                ms::fuzz::finding("read_query_csv accepted a query that validate_query rejects");
            }
        }
    } catch (const ms::CsvError&) {
    }
    return 0;
}
