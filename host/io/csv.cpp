#include "io/csv.hpp"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include "core/query.hpp"

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

}  // namespace

NumericCsv read_numeric_csv(const std::string& path, const std::vector<std::string>& expected) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw CsvError(path + ": is a directory, not a CSV file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CsvError(path + ": cannot open for reading");
    std::string line;
    std::size_t line_no = 0;
    // Header: the first non-blank line.
    std::vector<std::string> header;
    while (std::getline(in, line)) {
        ++line_no;
        if (line.find('\0') != std::string::npos) throw CsvError(path + ":" + std::to_string(line_no) + ": binary data, not CSV text");
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
    while (std::getline(in, line)) {
        ++line_no;
        if (trim(line).empty()) continue;
        if (line.find('\0') != std::string::npos) throw CsvError(path + ":" + std::to_string(line_no) + ": binary data, not CSV text");
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
