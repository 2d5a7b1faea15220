#include "io/input_file.hpp"

#include <cerrno>
#include <cstring>

#include "platform/files.hpp"

namespace ms {

namespace {

std::string describe_limit(std::uint64_t bytes) {
    if (bytes % (std::uint64_t(1) << 30) == 0) return std::to_string(bytes >> 30) + " GiB";
    if (bytes % (std::uint64_t(1) << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
    return std::to_string(bytes) + " bytes";
}

}  // namespace

void require_regular_file(const std::string& path, const std::string& what) {
    platform::FileStatus st;
    if (platform::path_status(path, st) != 0) throw InputError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
    if (st.kind == platform::FileKind::regular) return;
    const std::string kind = st.kind == platform::FileKind::other ? "not a regular file" : platform::kind_phrase(st.kind);
    throw InputError(path + ": is " + kind + ", not a regular file (a " + what + " is read from a file)");
}

std::string read_input_file(const std::string& path, std::uint64_t max_bytes, const std::string& what) {
    // Opened first, then checked with fstat: the same file is checked and read (no race with a rename),
    // and O_NONBLOCK keeps open() of a FIFO without a writer from hanging before the check.
    const int fd = platform::open_file(path, platform::read_only | platform::non_blocking);
    if (fd < 0) throw InputError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
    struct Closer {
        int fd;
        ~Closer() { platform::close_file(fd); }
    } closer{fd};
    using platform::FileKind;
    platform::FileStatus st;
    if (platform::descriptor_status(fd, st) != 0) throw InputError(path + ": cannot read (" + std::string(std::strerror(errno)) + ")");
    if (st.kind == FileKind::directory) throw InputError(path + ": is a directory, not a " + what + " file");
    if (st.kind == FileKind::character_device || st.kind == FileKind::block_device || st.kind == FileKind::socket)
        throw InputError(path + ": is a " + std::string(st.kind == FileKind::socket ? "socket" : "device") +
                         ", not a regular file; a " + what + " must be a file (at most " + describe_limit(max_bytes) + ")");
    if (st.kind == FileKind::regular && st.size > max_bytes)
        throw InputError(path + ": is " + std::to_string(st.size) + " bytes, more than the limit of " +
                         describe_limit(max_bytes) + " for a " + what);
    // Blocking reads from here (a pipe's writer may be slower than us).
    platform::make_blocking(fd);
    std::string data;
    if (st.kind == FileKind::regular) data.reserve(std::size_t(st.size));
    char buf[1 << 16];
    while (true) {
        const long long n = platform::read_some(fd, buf, sizeof buf);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw InputError(path + ": read error (" + std::string(std::strerror(errno)) + ")");
        }
        if (n == 0) break;
        // A FIFO, or a file that grows while read: the same limit, checked as the bytes arrive.
        if (data.size() + std::size_t(n) > max_bytes)
            throw InputError(path + ": more than the limit of " + describe_limit(max_bytes) + " for a " + what);
        data.append(buf, std::size_t(n));
    }
    return data;
}

}  // namespace ms
