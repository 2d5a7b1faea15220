// A sweep's chunks in the shared item store (schedule/chunk_store.hpp, schedule/distributed.hpp): chunk c
// is item c, its payload the chunk's CSV rows (no header), sealed, resumed, sharded, spread over MPI
// ranks and merged as every other job's items are. Beside the items the folder keeps sweep-spec.json,
// what the items are (the CSV header, the point and chunk counts, the spec and how its values were
// computed), so a merge needs nothing but the folder.
//
// Folders written before the item store (manifest.json or manifest.shard-I-of-N.json of format
// "microshadow-sweep-manifest/1" or "/2", chunks/chunk-XXXXXXXXXX.csv) are upgraded in place the first
// time a run or a merge reads them: each finished chunk that passes its checks becomes an item.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "schedule/chunk_store.hpp"

namespace ms::sweep {

// Checks a chunk's rows as any input: exactly the rows of points [first, last), each with `fields`
// fields, its point index first, its numbers finite, the term a fraction in [0, 1] and its error in
// [0, 1]. Returns "" when they are, else "tag: reason" (tags: rows, index, fields, values).
std::string check_chunk_rows(const std::string& rows, std::uint64_t first, std::uint64_t last, std::size_t fields);

// The file beside the items that says what they are.
constexpr const char* kSweepDescriptionFile = "sweep-spec.json";
constexpr const char* kSweepDescriptionFormat = "microshadow-sweep-store/1";

// Reads DIR/sweep-spec.json and checks its shape (format, spec_hash, header, points, chunk_size, chunks
// consistent with each other, tolerance >= 0). Throws std::invalid_argument naming the file.
nlohmann::json read_sweep_description(const std::string& dir);
void write_sweep_description(const std::string& dir, const nlohmann::json& description);
// The store key of the sweep a description describes: job "sweep", its spec hash and chunk count.
schedule::StoreKey sweep_store_key(const nlohmann::json& description);

// Upgrades a folder of the format before the item store in place (nothing to do in any other folder).
// Every old manifest must be of the sweep `expected_spec_hash` (when not empty): else
// std::invalid_argument, nothing changed. Chunks found damaged are set aside in chunks/rejected/ and
// `warn` is told; they count as not computed. Returns the number of chunks that became items.
std::uint64_t upgrade_old_sweep_folder(const std::string& dir, const std::string& expected_spec_hash,
                                       const std::function<void(const std::string&)>& warn);
// The spec hashes of the old manifests in DIR (empty when there are none).
std::vector<std::string> old_sweep_manifest_hashes(const std::string& dir);

}  // namespace ms::sweep
