#include "io/bounded_json.hpp"

#include <algorithm>

namespace ms {

std::size_t json_nesting_depth(const std::string& text) {
    std::size_t depth = 0, deepest = 0;
    bool in_string = false, escaped = false;
    for (const char c : text) {
        if (in_string) {
            if (escaped) escaped = false;
            else if (c == '\\') escaped = true;
            else if (c == '"') in_string = false;
            continue;
        }
        if (c == '"') in_string = true;
        else if (c == '[' || c == '{') deepest = std::max(deepest, ++depth);
        else if ((c == ']' || c == '}') && depth > 0) --depth;
    }
    return deepest;
}

nlohmann::json parse_bounded_json(const std::string& text, const std::string& what, std::size_t max_depth, std::size_t max_bytes) {
    if (text.size() > max_bytes)
        throw JsonLimitError(what + " is " + std::to_string(text.size()) + " bytes of JSON, more than the limit of " +
                             std::to_string(max_bytes));
    if (const std::size_t depth = json_nesting_depth(text); depth > max_depth)
        throw JsonLimitError(what + " nests " + std::to_string(depth) + " levels deep, more than the limit of " +
                             std::to_string(max_depth));
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded()) throw std::runtime_error(what + " is not JSON");
    return j;
}

}  // namespace ms
