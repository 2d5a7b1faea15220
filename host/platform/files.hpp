// Files beyond std::filesystem: descriptors that report errno, the kind of a node (FIFOs, devices and
// sockets are refused by the readers and writers), durable writes, hard links and the atomic replace
// of one file by another. POSIX and Win32 implementations (posix.cpp, win32.cpp); every function
// returns 0 (or a descriptor) on success and -1 with errno set on failure, like the calls they wrap.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace ms::platform {

enum class FileKind { missing, regular, directory, symlink, fifo, character_device, block_device, socket, other };

struct FileStatus {
    FileKind kind = FileKind::missing;
    std::uint64_t size = 0;
    unsigned permissions = 0;   // the rwx bits (07777 on POSIX; Windows reports 0666 or 0444)
    bool owned_by_user = true;  // owned by the running user (always true on Windows)
};

// lstat (the link itself), stat (its target) and fstat.
int link_status(const std::string& path, FileStatus& out);
int path_status(const std::string& path, FileStatus& out);
int descriptor_status(int fd, FileStatus& out);
// Which file `path` names, links followed: (st_dev, st_ino) on POSIX, (volume serial, file index) on
// Windows. Two paths name the same file exactly when their identities are equal.
struct FileIdentity {
    std::uint64_t device = 0, file = 0;
    bool operator<(const FileIdentity& o) const { return device != o.device ? device < o.device : file < o.file; }
    bool operator==(const FileIdentity& o) const { return device == o.device && file == o.file; }
};
int file_identity(const std::string& path, FileIdentity& out);
// "a directory", "a FIFO (named pipe)", "a character device", ... for messages.
const char* kind_phrase(FileKind kind);

// Flags of open_file; every descriptor is binary and not inherited by child processes.
enum OpenFlags : unsigned {
    read_only = 0,
    write_only = 1u << 0,
    read_write = 1u << 1,
    create = 1u << 2,
    truncate = 1u << 3,
    non_blocking = 1u << 4,  // an open of a FIFO without a writer returns at once (POSIX)
};
int open_file(const std::string& path, unsigned flags, unsigned permissions = 0666);
int close_file(int fd);
// One read or write call; EINTR is left to the caller, as with read(2) and write(2).
long long read_some(int fd, void* buffer, std::size_t bytes);
long long write_some(int fd, const void* buffer, std::size_t bytes);
// Clears non_blocking for the reads that follow.
int make_blocking(int fd);
// dup and dup2: a second descriptor of `fd`; `fd` made to refer to what `from` refers to (stderr sent
// to a file while a compiler writes to it).
int duplicate_descriptor(int fd);
int redirect_descriptor(int from, int to);
// The file's data on disk (fsync; _commit on Windows).
int sync_file(int fd);
// The named file's data on disk (Windows flushes only through a handle open for writing).
int sync_path(const std::string& path);
// The directory's entries on disk, best effort (a no-op on Windows, whose renames need none).
void sync_directory(const std::string& dir);
int set_permissions(int fd, unsigned permissions);
int hard_link(const std::string& existing, const std::string& link);
// Replaces `to` by `from` in one step (rename(2); MoveFileEx with REPLACE_EXISTING on Windows, where
// rename refuses an existing target).
int replace_file(const std::string& from, const std::string& to);
int remove_file(const std::string& path);
// Whether the running user may create files in `dir` (access(W_OK | X_OK)); errno says why not.
bool can_create_in(const std::string& dir);
// The longest file name `dir`'s file system takes (pathconf _PC_NAME_MAX; 255 on Windows).
long max_file_name(const std::string& dir);
// readlink: the link's text.
int read_link(const std::string& path, std::string& target);
// realpath: the absolute path with every link resolved.
int resolve_path(const std::string& path, std::string& resolved);
// mkstemp: replaces the trailing XXXXXX of `path_template` and creates the file; returns its descriptor.
int make_unique_file(std::string& path_template);

constexpr int kStandardOutput = 1;
constexpr int kStandardError = 2;

// An exclusive advisory lock held through `fd` (flock; LockFileEx on Windows): 0 when taken, 1 when
// another process holds it, -1 with errno on failure. The lock ends with the descriptor or the process,
// so a killed process leaves none behind.
int try_lock_exclusive(int fd);

}  // namespace ms::platform
