// One ALU rule for every comparator's cost (part 2's LUTs, representations, closed forms, part 1's terms
// written as GLSL): see alu_count.hpp.
#include "lut/shader/alu_count.hpp"

#include <cctype>
#include <set>
#include <string>

namespace ms::lutshader {

unsigned count_alu(const std::string& src) {
    static const std::set<std::string> one = {"sqrt", "inversesqrt", "exp",   "exp2",  "log",  "log2",      "abs",
                                              "min",  "max",         "clamp", "mix",   "step", "smoothstep", "fract",
                                              "floor", "ceil",       "fma",   "dot",   "sign", "saturate",  "rcp",
                                              "length", "normalize", "sin",   "cos",   "lerp", "frac",      "rsqrt",
                                              "acos", "asin", "atan", "tan"};
    unsigned count = 0;
    std::size_t i = 0;
    const std::size_t n = src.size();
    char previous = ' ';  // last significant character class: 'a' operand end, 'o' operator, ' ' none
    while (i < n) {
        const char c = src[i];
        if (c == '/' && i + 1 < n && src[i + 1] == '/') {  // comment to the end of the line
            while (i < n && src[i] != '\n') ++i;
            continue;
        }
        if (c == '#' && (i == 0 || src[i - 1] == '\n')) {  // preprocessor line
            while (i < n && src[i] != '\n') ++i;
            continue;
        }
        if (std::isspace(static_cast<unsigned char>(c))) {
            ++i;
            continue;
        }
        if (std::isdigit(static_cast<unsigned char>(c)) || (c == '.' && i + 1 < n && std::isdigit(static_cast<unsigned char>(src[i + 1])))) {
            // A literal, its exponent sign included (1e-05 is one literal, not a subtraction).
            while (i < n && (std::isalnum(static_cast<unsigned char>(src[i])) || src[i] == '.' ||
                             ((src[i] == '-' || src[i] == '+') && (src[i - 1] == 'e' || src[i - 1] == 'E'))))
                ++i;
            previous = 'a';
            continue;
        }
        if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
            std::size_t j = i;
            while (j < n && (std::isalnum(static_cast<unsigned char>(src[j])) || src[j] == '_')) ++j;
            const std::string word = src.substr(i, j - i);
            std::size_t k = j;
            while (k < n && std::isspace(static_cast<unsigned char>(src[k]))) ++k;
            if (k < n && src[k] == '(') {
                if (word == "pow") count += 3;
                else if (one.count(word)) count += 1;
                previous = 'o';  // a call: what follows is its '('
            } else {
                previous = (word == "return") ? 'o' : 'a';
            }
            i = j;
            continue;
        }
        const std::string two = src.substr(i, 2);
        if (two == "+=" || two == "-=" || two == "*=" || two == "/=" || two == "<=" || two == ">=" || two == "==" ||
            two == "!=" || two == "&&" || two == "||") {
            ++count;
            previous = 'o';
            i += 2;
            continue;
        }
        if (c == '+' || c == '-' || c == '*' || c == '/') {
            if (previous == 'a') ++count;  // binary; a unary sign is a free source modifier
            previous = 'o';
        } else if (c == '<' || c == '>' || c == '?') {
            ++count;
            previous = 'o';
        } else if (c == ')' || c == ']') {
            previous = 'a';
        } else {
            previous = 'o';
        }
        ++i;
    }
    return count;
}

}  // namespace ms::lutshader
