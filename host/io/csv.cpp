#include "io/csv.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/query.hpp"
#include "io/input_file.hpp"
#include "io/input_guard.hpp"
#include "io/text.hpp"

namespace ms {

const std::vector<std::string> kQueryColumns = {"visibility", "alpha_x", "alpha_y", "wi_x", "wi_y",
                                                "wi_z",       "wo_x",    "wo_y",    "wo_z"};

namespace {

std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) return "";
    const auto e = s.find_last_not_of(" \t\r");
    return s.substr(b, e - b + 1);
}

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> out;
    std::size_t start = 0;
    while (true) {
        const auto comma = line.find(',', start);
        out.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
        if (comma == std::string::npos) return out;
        start = comma + 1;
    }
}

std::string printable(const std::string& s) {
    std::string out;
    for (unsigned char c : s.substr(0, 40)) out += (c >= 32 && c < 127) ? char(c) : '?';
    return s.size() > 40 ? out + "..." : out;
}

// Checks every byte before any line is parsed, so a binary or wrongly encoded file is reported at its
// first bad byte with line and column (and not as "unknown column" or "duplicate column" later):
// a UTF-8 byte-order mark is skipped; UTF-16/32 (by their marks), NUL, control characters and bytes
// that are not UTF-8 are refused; CRLF is accepted, CR-only (classic Mac) line endings are refused,
// since they would read as one line. Returns the offset where the text starts (after a BOM).
std::size_t check_bytes(const std::string& path, const std::string& data) {
    auto starts = [&](const char* prefix, std::size_t n) { return data.size() >= n && data.compare(0, n, prefix, n) == 0; };
    if (starts("\x00\x00\xFE\xFF", 4) || starts("\xFF\xFE\x00\x00", 4))
        throw CsvError(path + ":1: binary data, not CSV text (a UTF-32 byte-order mark); save the file as UTF-8 or ASCII");
    if (starts("\xFF\xFE", 2) || starts("\xFE\xFF", 2))
        throw CsvError(path + ":1: binary data, not CSV text (a UTF-16 byte-order mark); save the file as UTF-8 or ASCII");
    const std::size_t begin = starts("\xEF\xBB\xBF", 3) ? 3 : 0;
    std::size_t line = 1, line_start = begin;
    for (std::size_t i = begin; i < data.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(data[i]);
        const std::size_t column = i - line_start + 1;
        auto where = [&] { return path + ":" + std::to_string(line) + ": "; };
        auto hex = [&] {
            char b[8];
            std::snprintf(b, sizeof b, "0x%02X", c);
            return std::string(b);
        };
        if (c == '\n') {
            ++line;
            line_start = i + 1;
        } else if (c == '\r') {
            if (i + 1 < data.size() && data[i + 1] != '\n')
                throw CsvError(where() + "a carriage return without a line feed at column " + std::to_string(column) +
                               ": CR-only (classic Mac) line endings are not supported; save the file with LF or CRLF line endings");
        } else if (c == 0) {
            throw CsvError(where() + "binary data, not CSV text (a NUL byte at column " + std::to_string(column) + ")");
        } else if ((c < 0x20 && c != '\t') || c == 0x7F) {
            throw CsvError(where() + "binary data, not CSV text (control character " + hex() + " at column " +
                           std::to_string(column) + ")");
        } else if (c >= 0x80) {
            if (utf8_length_at(data, i) == 0)
                throw CsvError(where() + "binary data, not CSV text (byte " + hex() + " at column " + std::to_string(column) +
                               " is not UTF-8)");
            throw CsvError(where() + "a non-ASCII character at column " + std::to_string(column) +
                           ": a query file holds ASCII column names and numbers only");
        }
    }
    return begin;
}

}  // namespace

NumericCsv read_numeric_csv(const std::string& path, const std::vector<std::string>& expected) {
    std::string data;
    try {
        note_input(path);
        data = read_input_file(path, kMaxCsvBytes, "CSV");
    } catch (const InputError& e) {
        throw CsvError(e.what());
    }
    const std::size_t text_begin = check_bytes(path, data);
    std::size_t pos = text_begin;
    // One line at a time from the checked text, without its line feed (and a CRLF's carriage return).
    auto next_line = [&](std::string& line) {
        if (pos >= data.size()) return false;
        std::size_t nl = data.find('\n', pos);
        if (nl == std::string::npos) nl = data.size();
        line.assign(data, pos, nl - pos);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        pos = nl + 1;
        return true;
    };
    std::string line;
    std::size_t line_no = 0;
    // Header: the first non-blank line.
    std::vector<std::string> header;
    while (next_line(line)) {
        ++line_no;
        if (!trim(line).empty()) {
            header = split(line);
            break;
        }
    }
    std::string expected_list;
    for (const auto& e : expected) expected_list += (expected_list.empty() ? "" : ",") + e;
    if (header.empty()) throw CsvError(path + ": empty file; expected a header line: " + expected_list);

    std::map<std::string, std::size_t> position;
    for (std::size_t j = 0; j < header.size(); ++j) {
        if (header[j].empty()) throw CsvError(path + ":" + std::to_string(line_no) + ": empty column name in header (column " + std::to_string(j + 1) + ")");
        if (position.count(header[j])) throw CsvError(path + ":" + std::to_string(line_no) + ": duplicate column '" + printable(header[j]) + "'");
        position[header[j]] = j;
    }
    for (const auto& name : header) {
        bool known = false;
        for (const auto& e : expected) known |= (e == name);
        if (!known) throw CsvError(path + ":" + std::to_string(line_no) + ": unknown column '" + printable(name) + "'; expected: " + expected_list);
    }
    std::vector<std::size_t> order;
    for (const auto& e : expected) {
        auto it = position.find(e);
        if (it == position.end()) throw CsvError(path + ":" + std::to_string(line_no) + ": missing column '" + e + "'; expected: " + expected_list);
        order.push_back(it->second);
    }

    NumericCsv table;
    table.columns = expected;
    while (next_line(line)) {
        ++line_no;
        if (trim(line).empty()) continue;
        const auto fields = split(line);
        if (fields.size() != header.size())
            throw CsvError(path + ":" + std::to_string(line_no) + ": " + std::to_string(fields.size()) + " fields, but the header has " + std::to_string(header.size()));
        std::vector<double> row(expected.size());
        for (std::size_t k = 0; k < expected.size(); ++k) {
            const std::string& text = fields[order[k]];
            double value = 0;
            // from_chars takes no leading '+'; accept one, as every CSV writer may emit it.
            const char* begin = text.data() + (text.size() > 1 && text[0] == '+' && text[1] != '-' ? 1 : 0);
            const auto [end, ec] = std::from_chars(begin, text.data() + text.size(), value);
            const std::string where = path + ":" + std::to_string(line_no) + ": column '" + expected[k] + "': ";
            if (text.empty()) throw CsvError(where + "empty field");
            if (ec == std::errc::result_out_of_range) throw CsvError(where + "'" + printable(text) + "' is out of the range of a double");
            if (ec != std::errc() || end != text.data() + text.size()) throw CsvError(where + "'" + printable(text) + "' is not a number");
            if (!std::isfinite(value)) throw CsvError(where + "'" + printable(text) + "' is not a finite number");
            row[k] = value;
        }
        table.rows.push_back(std::move(row));
        table.lines.push_back(line_no);
    }
    return table;
}

std::vector<Query> read_query_csv(const std::string& path) {
    const NumericCsv table = read_numeric_csv(path, kQueryColumns);
    std::vector<Query> queries;
    queries.reserve(table.rows.size());
    for (std::size_t i = 0; i < table.rows.size(); ++i) {
        const auto& r = table.rows[i];
        Query q;
        q.visibility = r[0];
        q.alpha_x = r[1];
        q.alpha_y = r[2];
        q.wi = {r[3], r[4], r[5]};
        q.wo = {r[6], r[7], r[8]};
        const std::string where = path + ":" + std::to_string(table.lines[i]) + " (row " + std::to_string(i + 1) + "): ";
        if (q.visibility < 0 || q.visibility > 1) throw CsvError(where + "column 'visibility': " + format_number(q.visibility) + " is outside [0, 1]");
        if (!(q.alpha_x > 0)) throw CsvError(where + "column 'alpha_x': " + format_number(q.alpha_x) + " must be > 0");
        if (!(q.alpha_y > 0)) throw CsvError(where + "column 'alpha_y': " + format_number(q.alpha_y) + " must be > 0");
        // hypot: tiny or huge components are valid directions as long as the length is representable.
        const double li = std::hypot(q.wi.x, q.wi.y, q.wi.z);
        const double lo = std::hypot(q.wo.x, q.wo.y, q.wo.z);
        if (!(li > 0) || !std::isfinite(li)) throw CsvError(where + "columns 'wi_x,wi_y,wi_z': zero-length or overflowing direction");
        if (!(lo > 0) || !std::isfinite(lo)) throw CsvError(where + "columns 'wo_x,wo_y,wo_z': zero-length or overflowing direction");
        if (!(q.wi.z / li > 0)) throw CsvError(where + "column 'wi_z': the view direction wi must be above the horizon (wi_z > 0)");
        queries.push_back(q);
    }
    return queries;
}

std::string format_number(double value) {
    char buf[64];
    const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, value);
    return ec == std::errc() ? std::string(buf, end) : std::to_string(value);
}

}  // namespace ms
