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
    try {
        const ms::NumericCsv t = ms::read_numeric_csv(path, {"a", "b"});
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
