#include "io/text.hpp"

#include <algorithm>

#include <cctype>
#include <cstdio>
#include <vector>

namespace ms {

namespace {

// Length of the valid UTF-8 sequence at s[i], or 0 when the byte there does not start one (overlong
// forms, surrogates and code points above U+10FFFF are invalid, as RFC 3629 says).
std::size_t utf8_sequence(std::string_view s, std::size_t i) {
    const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
    const unsigned char c = b(i);
    if (c < 0x80) return 1;
    std::size_t n = 0;
    unsigned lo = 0x80, hi = 0xBF;
    if (c >= 0xC2 && c <= 0xDF) n = 2;
    else if (c == 0xE0) n = 3, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEC) n = 3;
    else if (c == 0xED) n = 3, hi = 0x9F;
    else if (c >= 0xEE && c <= 0xEF) n = 3;
    else if (c == 0xF0) n = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) n = 4;
    else if (c == 0xF4) n = 4, hi = 0x8F;
    else return 0;
    if (i + n > s.size()) return 0;
    if (b(i + 1) < lo || b(i + 1) > hi) return 0;
    for (std::size_t k = 2; k < n; ++k)
        if (b(i + k) < 0x80 || b(i + k) > 0xBF) return 0;
    return n;
}

std::string hex_byte(unsigned char c) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "\\x%02X", c);
    return buf;
}

}  // namespace

std::size_t utf8_length_at(std::string_view s, std::size_t i) { return i < s.size() ? utf8_sequence(s, i) : 0; }

bool is_valid_utf8(std::string_view s) {
    for (std::size_t i = 0; i < s.size();) {
        const std::size_t n = utf8_sequence(s, i);
        if (n == 0) return false;
        i += n;
    }
    return true;
}

std::string json_safe(std::string_view s) {
    std::string out;
    out.reserve(s.size());
    for (std::size_t i = 0; i < s.size();) {
        const std::size_t n = utf8_sequence(s, i);
        if (n == 0) {
            out += hex_byte(static_cast<unsigned char>(s[i]));
            ++i;
        } else {
            out.append(s.substr(i, n));
            i += n;
        }
    }
    return out;
}

std::string dump_json(const nlohmann::json& j, int indent) {
    return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string shell_quote(std::string_view arg) {
    bool plain = !arg.empty();
    bool needs_ansi = false;  // control or invalid bytes: only bash's $'...' can spell them
    for (std::size_t i = 0; i < arg.size();) {
        const unsigned char c = static_cast<unsigned char>(arg[i]);
        const std::size_t n = utf8_sequence(arg, i);
        if (n == 0 || c < 0x20 || c == 0x7F) needs_ansi = true;
        if (!(std::isalnum(c) || std::string_view("-_./=:,+@%").find(char(c)) != std::string_view::npos)) plain = false;
        i += n ? n : 1;
    }
    if (plain) return std::string(arg);
    if (!needs_ansi) {
        std::string out = "'";
        for (char c : arg) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
        return out + "'";
    }
    std::string out = "$'";
    for (std::size_t i = 0; i < arg.size();) {
        const unsigned char c = static_cast<unsigned char>(arg[i]);
        const std::size_t n = utf8_sequence(arg, i);
        if (n == 0 || c < 0x20 || c == 0x7F) {
            out += hex_byte(c);
            ++i;
        } else if (c == '\'' || c == '\\') {
            out += '\\';
            out += char(c);
            ++i;
        } else {
            out.append(arg.substr(i, n));
            i += n;
        }
    }
    return out + "'";
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

std::string format_g(double v, int digits) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

std::string to_upper(std::string s) {
    for (char& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

}  // namespace ms
