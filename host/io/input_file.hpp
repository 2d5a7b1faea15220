// Input files read whole into memory (query CSVs, sweep specs), bounded before a byte is read:
// `eval --in /dev/zero` read a gigabyte of NULs before saying "empty file", `sweep /dev/zero` ended in
// std::bad_alloc. The rule: a regular file up to a documented limit, or a FIFO / pipe (for
// `--in <(command)`), read up to the same limit; a directory, a device or a socket is refused.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace ms {

class InputError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

// Largest query CSV `eval` reads (1 GiB: about 15 million queries).
inline constexpr std::uint64_t kMaxCsvBytes = std::uint64_t(1) << 30;
// Largest sweep spec (16 MiB; real specs are a few hundred bytes).
inline constexpr std::uint64_t kMaxSpecBytes = std::uint64_t(16) << 20;

// The whole content of `path`, checked as above. `what` names the input in messages ("query CSV").
// Throws InputError: "PATH: cannot open for reading (...)", "PATH: is a directory, not a WHAT",
// "PATH: is a character device, not a regular file", "PATH: is N bytes, more than the limit of ...".
std::string read_input_file(const std::string& path, std::uint64_t max_bytes, const std::string& what);

// For inputs read by position (LUTs, representations, images, sidecars): only a regular file (or a
// symlink to one). Checked with stat, never open: opening a FIFO without a writer blocks, where no
// SIGINT or SIGTERM reaches the reader. Throws InputError "PATH: is a FIFO (named pipe), not a regular
// file (WHAT is read from a file)" (also for a directory, a device, a socket) or "PATH: cannot open
// for reading (...)".
void require_regular_file(const std::string& path, const std::string& what);

}  // namespace ms
