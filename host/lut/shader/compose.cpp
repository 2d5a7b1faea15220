#include "lut/shader/compose.hpp"

#include "lut/shader/wgsl.hpp"

#include <cctype>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <utility>

namespace ms::lutshader {

ShaderLanguage parse_shader_language(const std::string& s) {
    if (s == "glsl") return ShaderLanguage::glsl;
    if (s == "hlsl") return ShaderLanguage::hlsl;
    if (s == "wgsl") return ShaderLanguage::wgsl;
    throw std::invalid_argument("--lang must be glsl, hlsl or wgsl, not '" + s + "'");
}

std::string to_string(ShaderLanguage l) { return l == ShaderLanguage::glsl ? "glsl" : l == ShaderLanguage::hlsl ? "hlsl" : "wgsl"; }

namespace {

// The shared helpers in GLSL spelling, in the order the common block holds them.
const std::vector<std::pair<std::string, std::string>>& helpers_glsl() {
    static const std::vector<std::pair<std::string, std::string>> helpers = {
        {"ms_asinh",
         "// asinh(x) written out, odd so that it keeps its precision for x << 0 (HLSL has no asinh).\n"
         "float ms_asinh(float x)\n{\n    float a = abs(x);\n    return sign(x) * log(a + sqrt(a * a + 1.0));\n}\n"},
        {"ms_area_angle", "float ms_area_angle(vec3 a, vec3 b) { return atan(length(cross(a, b)), dot(a, b)); }\n"},
        {"ms_area_lambda",
         "// Smith's Lambda of anisotropic GGX for the direction w (tangent frame).\n"
         "float ms_area_lambda(vec3 w, float ax, float ay) {\n"
         "    float a = (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z);\n"
         "    return a / (2.0 * (1.0 + sqrt(1.0 + a)));\n}\n"},
        {"ms_area_lobe_weight",
         "// W = f cos of the lobe towards wo: Lambert (lobe 0) or GGX (lobe 1, height-correlated Smith, F = 1).\n"
         "float ms_area_lobe_weight(vec3 wi, vec3 wo, float ax, float ay, int lobe) {\n"
         "    if (wo.z <= 0.0) return 0.0;\n"
         "    if (lobe == 0) return wo.z * 0.31830988618;\n"
         "    vec3 h = normalize(wi + wo);\n"
         "    float ex = h.x / ax, ey = h.y / ay;\n"
         "    float s = ex * ex + ey * ey + h.z * h.z;\n"
         "    float d = 1.0 / (3.14159265359 * ax * ay * s * s);\n"
         "    return d / (4.0 * wi.z * (1.0 + ms_area_lambda(wi, ax, ay) + ms_area_lambda(wo, ax, ay)));\n}\n"},
        {"ms_rect_gauss_node",
         "// The 3-point Gauss-Legendre rule on [0, 1]: node and weight of point a.\n"
         "float ms_rect_gauss_node(int a) { return a == 0 ? 0.11270166538 : (a == 1 ? 0.5 : 0.88729833462); }\n"},
        {"ms_rect_gauss_weight", "float ms_rect_gauss_weight(int a) { return a == 1 ? 0.44444444444 : 0.27777777778; }\n"},
    };
    return helpers;
}

void replace_all(std::string& s, const std::string& from, const std::string& to) {
    for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
}

bool identifier_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

bool is_shared(const std::string& name) {
    for (const auto& h : helpers_glsl())
        if (h.first == name) return true;
    return false;
}

// A guard name that changes with the block's text: files whose helpers differ do not silently share one.
std::string text_hash(const std::string& s) {
    std::uint32_t h = 2166136261u;  // FNV-1a
    for (unsigned char c : s) h = (h ^ c) * 16777619u;
    char buf[9];
    std::snprintf(buf, sizeof buf, "%08X", unsigned(h));
    return buf;
}

}  // namespace

std::string shared_helper(const std::string& name, ShaderLanguage language) {
    for (const auto& [n, text] : helpers_glsl()) {
        if (n != name) continue;
        std::string s = text;
        if (language == ShaderLanguage::wgsl) return glsl_to_wgsl(s);
        if (language == ShaderLanguage::hlsl) {
            // The GLSL spellings the helpers use that HLSL spells otherwise.
            replace_all(s, "vec3", "float3");
            replace_all(s, "atan(", "atan2(");
        }
        return s;
    }
    throw std::logic_error("no shared shader helper " + name);
}

std::string common_block(ShaderLanguage language) {
    std::string body;
    for (const auto& h : helpers_glsl()) body += shared_helper(h.first, language) + "\n";
    const std::string guard = "MICROSHADOW_COMMON_" + text_hash(body);
    return "// Helpers every microshadow shader shares: the same text in each generated file that uses them,\n"
           "// defined by the first one included.\n#ifndef " + guard + "\n#define " + guard + "\n\n" + body + "#endif\n\n";
}

std::string default_prefix(const std::string& output_path) {
    if (output_path.empty() || output_path == "-") return "ms";
    std::string prefix;
    for (char c : std::filesystem::path(output_path).stem().string()) {
        const char k = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
        if (k == '_' && (prefix.empty() || prefix.back() == '_')) continue;
        prefix += k;
    }
    while (!prefix.empty() && prefix.back() == '_') prefix.pop_back();
    if (prefix.empty()) return "ms";
    if (std::isdigit(static_cast<unsigned char>(prefix[0])) || prefix.rfind("gl_", 0) == 0) prefix = "ms_" + prefix;
    return prefix;
}

void check_prefix(const std::string& prefix) {
    bool ok = !prefix.empty() && std::isalpha(static_cast<unsigned char>(prefix[0])) && prefix.back() != '_' &&
              prefix.find("__") == std::string::npos && prefix.rfind("gl_", 0) != 0;
    for (char c : prefix) ok = ok && identifier_char(c);
    if (!ok)
        throw std::invalid_argument("--shader-prefix '" + prefix +
                                    "': a letter, then letters, digits or single underscores, not ending in '_' and not "
                                    "starting with gl_");
}

std::string compose(const std::string& generated, ShaderLanguage language, const std::string& prefix) {
    check_prefix(prefix);
    std::string own = generated;
    bool uses_helpers = false;
    // WGSL has no preprocessor, so no guards: its files share nothing, every name they define (shared
    // helpers too) carries the file's prefix, and files with different prefixes concatenate.
    const bool wgsl = language == ShaderLanguage::wgsl;
    for (const auto& h : helpers_glsl()) {
        if (wgsl) break;
        const std::string text = shared_helper(h.first, language);
        const std::size_t at = own.find(text);
        if (at == std::string::npos) continue;
        const bool blank_after = at + text.size() < own.size() && own[at + text.size()] == '\n';
        own.erase(at, text.size() + (blank_after ? 1 : 0));
        uses_helpers = true;
    }
    // The file's own ms_ names (functions, parameters) become prefix_ names; shared helpers keep theirs.
    std::string renamed;
    renamed.reserve(own.size() + 256);
    for (std::size_t i = 0; i < own.size();) {
        if (own.compare(i, 3, "ms_") == 0 && (i == 0 || !identifier_char(own[i - 1]))) {
            std::size_t j = i;
            while (j < own.size() && identifier_char(own[j])) ++j;
            const std::string name = own.substr(i, j - i);
            renamed += is_shared(name) && !wgsl ? name : prefix + name.substr(2);
            i = j;
        } else {
            renamed += own[i++];
        }
    }
    if (wgsl)
        return "// Names defined here start with " + prefix + "_ (WGSL has no include guards: include each file once).\n" + renamed;
    const std::string guard = "MICROSHADOW_" + prefix + "_INCLUDED";
    return (uses_helpers ? common_block(language) : std::string()) + "#ifndef " + guard + "\n#define " + guard + "\n" +
           renamed + (renamed.empty() || renamed.back() == '\n' ? "" : "\n") + "#endif  // " + guard + "\n";
}

}  // namespace ms::lutshader
