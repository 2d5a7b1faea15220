#include "lut/shader/alu_count.hpp"

#include <cctype>
#include <iterator>
#include <regex>
#include <sstream>

namespace ms::lutshader {

unsigned count_alu(const std::string& source) {
    unsigned count = 0;
    std::istringstream in(source);
    std::string line;
    static const std::regex intrinsic(R"(\b(clamp|mix|lerp|min|max|floor|sqrt|acos|dot|abs|cos)\s*\()");
    while (std::getline(in, line)) {
        const auto comment = line.find("//");
        if (comment != std::string::npos) line.resize(comment);
        count += unsigned(std::distance(std::sregex_iterator(line.begin(), line.end(), intrinsic), std::sregex_iterator()));
        // Operators: a + - * / after an operand is binary (a '-' after '(' or ',' is a sign); numbers
        // are skipped whole (their exponent sign is no operator); comparisons, && and || count once.
        bool after_operand = false;
        for (std::size_t i = 0; i < line.size();) {
            const char c = line[i];
            if (std::isdigit((unsigned char)c) || (c == '.' && i + 1 < line.size() && std::isdigit((unsigned char)line[i + 1]))) {
                while (i < line.size() && (std::isalnum((unsigned char)line[i]) || line[i] == '.' ||
                                           ((line[i] == '-' || line[i] == '+') && (line[i - 1] == 'e' || line[i - 1] == 'E'))))
                    ++i;
                after_operand = true;
            } else if (std::isalpha((unsigned char)c) || c == '_') {
                while (i < line.size() && (std::isalnum((unsigned char)line[i]) || line[i] == '_')) ++i;
                after_operand = true;
            } else if (c == ')' || c == ']') {
                after_operand = true, ++i;
            } else if (c == '+' || c == '-' || c == '*' || c == '/') {
                if (after_operand) ++count;
                after_operand = false, ++i;
                if (i < line.size() && line[i] == '=') ++i;
            } else if (c == '<' || c == '>' || (c == '=' && i + 1 < line.size() && line[i + 1] == '=') ||
                       (c == '&' && i + 1 < line.size() && line[i + 1] == '&') || (c == '|' && i + 1 < line.size() && line[i + 1] == '|') ||
                       c == '?') {
                ++count;
                after_operand = false;
                i += (i + 1 < line.size() && (line[i + 1] == '=' || line[i + 1] == '&' || line[i + 1] == '|')) ? 2 : 1;
            } else {
                if (!std::isspace((unsigned char)c)) after_operand = false;
                ++i;
            }
        }
    }
    return count;
}

}  // namespace ms::lutshader
