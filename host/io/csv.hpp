// Strict numeric CSV: a header line of column names, then rows of finite numbers. Every problem is
// reported with the file, line and column; nothing is guessed.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace ms {

class CsvError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct NumericCsv {
    std::vector<std::string> columns;
    std::vector<std::vector<double>> rows;  // rows[i][j] is column j of data row i
    std::vector<std::size_t> lines;         // 1-based line number of each data row
};

// Reads `path`; the header must contain exactly the `expected` columns, in any order (no missing,
// unknown or duplicate names). Rows must have as many fields as the header and hold finite numbers
// (no NaN, no infinity, no overflow). Blank lines and a trailing newline are allowed. Throws CsvError.
// Returns columns in the `expected` order.
NumericCsv read_numeric_csv(const std::string& path, const std::vector<std::string>& expected);

// The query file of `microshadow eval`.
extern const std::vector<std::string> kQueryColumns;  // visibility,alpha_x,alpha_y,wi_x,...,wo_z

// Reads and validates queries (visibility in [0,1], alpha > 0, non-zero directions, wi above the
// horizon); directions are returned as written (the evaluator normalises). Throws CsvError naming
// the row and column.
std::vector<Query> read_query_csv(const std::string& path);

// Shortest decimal text that reads back to the same double.
std::string format_number(double value);

}  // namespace ms
