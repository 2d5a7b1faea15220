#include "io/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace ms {

namespace {

std::string describe_limit(std::uint64_t bytes) {
    if (bytes % (std::uint64_t(1) << 30) == 0) return std::to_string(bytes >> 30) + " GiB";
    if (bytes % (std::uint64_t(1) << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
    return std::to_string(bytes) + " bytes";
}

}  // namespace

void require_regular_file(const std::string& path, const std::string& what) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) throw InputError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
    if (S_ISREG(st.st_mode)) return;
    const char* kind = S_ISDIR(st.st_mode)    ? "a directory"
                       : S_ISFIFO(st.st_mode) ? "a FIFO (named pipe)"
                       : S_ISCHR(st.st_mode)  ? "a character device"
                       : S_ISBLK(st.st_mode)  ? "a block device"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "not a regular file";
    throw InputError(path + ": is " + kind + ", not a regular file (a " + what + " is read from a file)");
}

std::string read_input_file(const std::string& path, std::uint64_t max_bytes, const std::string& what) {
    // Opened first, then checked with fstat: the same file is checked and read (no race with a rename),
    // and O_NONBLOCK keeps open() of a FIFO without a writer from hanging before the check.
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) throw InputError(path + ": cannot open for reading (" + std::strerror(errno) + ")");
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    struct stat st {};
    if (::fstat(fd, &st) != 0) throw InputError(path + ": cannot read (" + std::string(std::strerror(errno)) + ")");
    if (S_ISDIR(st.st_mode)) throw InputError(path + ": is a directory, not a " + what + " file");
    if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) || S_ISSOCK(st.st_mode))
        throw InputError(path + ": is a " + std::string(S_ISSOCK(st.st_mode) ? "socket" : "device") +
                         ", not a regular file; a " + what + " must be a file (at most " + describe_limit(max_bytes) + ")");
    if (S_ISREG(st.st_mode) && std::uint64_t(st.st_size) > max_bytes)
        throw InputError(path + ": is " + std::to_string(st.st_size) + " bytes, more than the limit of " +
                         describe_limit(max_bytes) + " for a " + what);
    // Blocking reads from here (a pipe's writer may be slower than us).
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    std::string data;
    if (S_ISREG(st.st_mode)) data.reserve(std::size_t(st.st_size));
    char buf[1 << 16];
    while (true) {
        const ssize_t n = ::read(fd, buf, sizeof buf);
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
