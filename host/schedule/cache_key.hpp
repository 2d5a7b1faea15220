// The one cache key of every resumable job (its chunk store, a sweep's manifest, a reference set's
// cached file): each option that decides the bits of the job's items, by name, in one canonical JSON
// text (names sorted, numbers in their shortest round-trip form) whose FNV-1a 64 is the key. Every job
// builds its key from its option structs (jobs/cache_keys.hpp), and lists the options it leaves out
// (a path, a progress callback, a thread count: nothing that reaches a bit), each with the reason.
//
// The program's version and the fingerprint of its sources (source_fingerprint.hpp) are always part of
// the key: other code may compute other bits (a new quadrature rule, a kernel's rounding) under the same
// version number, so a run never resumes a store that other code began.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "schedule/chunk_store.hpp"

namespace ms::schedule {

class CacheKey {
public:
    // `job`: the store's job name ("bake", "sweep", ...), itself part of the key.
    explicit CacheKey(std::string job);

    // One option by its name ("plan.samples"); std::logic_error for a name added twice (two options
    // under one name would hide one of them).
    CacheKey& add(const std::string& name, nlohmann::json value);
    // A constant of the job's format (a cached file's format number): part of the key, moved only by a
    // new format, so not among names().
    CacheKey& constant(const std::string& name, nlohmann::json value);
    // A file by its bytes (FNV-1a), not its name: renaming it keeps the key, editing it does not.
    // std::runtime_error naming the file when it cannot be read.
    CacheKey& add_file(const std::string& name, const std::string& path);

    const std::string& job() const { return job_; }
    // The options' names, sorted (tests check that every option of a job's structs is among them).
    std::vector<std::string> names() const;
    std::string canonical_text() const;
    std::string hash() const;  // 16 hex digits of FNV-1a 64 of canonical_text()
    StoreKey store_key(std::uint64_t items) const { return {job_, hash(), items}; }

private:
    std::string job_;
    nlohmann::json fields_ = nlohmann::json::object();
};

}  // namespace ms::schedule
