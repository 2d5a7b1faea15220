// Result tables of the benchmarks: aligned text for the terminal, CSV for docs/bench/.
#include <algorithm>
#include <cstdio>
#include <ostream>

#include "bench.hpp"
#include "io/atomic_file.hpp"

namespace ms::bench {

std::string fmt(double value, int precision) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", precision, value);
    return buf;
}

void Table::print(std::ostream& out) const {
    std::vector<std::size_t> width(columns.size());
    for (std::size_t c = 0; c < columns.size(); ++c) width[c] = columns[c].size();
    for (const auto& row : rows)
        for (std::size_t c = 0; c < row.size() && c < width.size(); ++c) width[c] = std::max(width[c], row[c].size());
    auto line = [&](const std::vector<std::string>& cells) {
        for (std::size_t c = 0; c < cells.size(); ++c) {
            out << (c ? "  " : "") << cells[c];
            if (c + 1 < cells.size()) out << std::string(width[c] - cells[c].size(), ' ');
        }
        out << "\n";
    };
    out << "== " << name << " ==\n";
    line(columns);
    for (const auto& row : rows) line(row);
    out.flush();
}

void Table::write_csv(const std::string& path) const {
    check_writable_destination(path);
    AtomicFile file(path);
    auto& out = file.stream();
    auto line = [&](const std::vector<std::string>& cells) {
        for (std::size_t c = 0; c < cells.size(); ++c) {
            // Quote cells holding a comma or quote (device names can).
            const bool quote = cells[c].find_first_of(",\"") != std::string::npos;
            std::string cell = cells[c];
            if (quote) {
                std::string q = "\"";
                for (char ch : cell) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
                cell = q + "\"";
            }
            out << (c ? "," : "") << cell;
        }
        out << "\n";
    };
    line(columns);
    for (const auto& row : rows) line(row);
    file.commit();
}

}  // namespace ms::bench
