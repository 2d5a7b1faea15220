#include "schedule/cache_key.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "core/digest.hpp"
#include "device/runtime.hpp"
#include "schedule/source_fingerprint.hpp"

namespace ms::schedule {

namespace {
// The version of the key's own text: a change of how options are written moves every key.
constexpr int kCacheKeyFormat = 1;
}  // namespace

CacheKey::CacheKey(std::string job) : job_(std::move(job)) {
    fields_["$format"] = kCacheKeyFormat;
    fields_["$job"] = job_;
    // The version and the sources' fingerprint: a build from other sources may compute other bits.
    fields_["$version"] = std::string(MICROSHADOW_VERSION) + "+" + source_fingerprint();
    // Kernels read from $MICROSHADOW_KERNEL_DIR instead of the embedded ones: their bytes too.
    if (const std::string kernels = ocl::overridden_kernels_digest(); !kernels.empty()) fields_["$kernels"] = kernels;
}

CacheKey& CacheKey::add(const std::string& name, nlohmann::json value) {
    if (fields_.contains(name)) throw std::logic_error("cache key of " + job_ + ": option '" + name + "' added twice");
    fields_[name] = std::move(value);
    return *this;
}

CacheKey& CacheKey::constant(const std::string& name, nlohmann::json value) { return add("$" + name, std::move(value)); }

CacheKey& CacheKey::add_file(const std::string& name, const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot read it (" + std::strerror(errno) + ")");
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw std::runtime_error(path + ": cannot read it");
    return add(name, "fnv1a " + hex16(fnv1a(bytes)));
}

std::vector<std::string> CacheKey::names() const {
    std::vector<std::string> names;
    for (const auto& item : fields_.items())
        if (item.key().front() != '$') names.push_back(item.key());
    return names;
}

std::string CacheKey::canonical_text() const {
    // nlohmann's object keeps its names sorted, and writes a double in the shortest form that reads
    // back to the same bits: two values that differ in any bit are two texts. Bytes that are not UTF-8
    // (a path) are replaced rather than refused; the key is a digest, never read back.
    return fields_.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string CacheKey::hash() const { return hex16(fnv1a(canonical_text())); }

}  // namespace ms::schedule
