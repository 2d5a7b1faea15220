// The POSIX implementation of the platform layer (Linux, and other Unix-like systems).
#ifndef _WIN32

#include <dlfcn.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <system_error>
#include <thread>

#include "platform/dynamic_library.hpp"
#include "platform/files.hpp"
#include "platform/memory.hpp"
#include "platform/process.hpp"
#include "platform/signals.hpp"

extern char** environ;

namespace ms::platform {

namespace {

FileStatus status_of(const struct stat& st) {
    FileStatus s;
    const mode_t m = st.st_mode;
    s.kind = S_ISREG(m) ? FileKind::regular : S_ISDIR(m) ? FileKind::directory : S_ISLNK(m) ? FileKind::symlink
           : S_ISFIFO(m) ? FileKind::fifo : S_ISCHR(m) ? FileKind::character_device : S_ISBLK(m) ? FileKind::block_device
           : S_ISSOCK(m) ? FileKind::socket : FileKind::other;
    s.size = std::uint64_t(st.st_size);
    s.permissions = unsigned(m & 07777);
    s.owned_by_user = st.st_uid == ::getuid();
    return s;
}

}  // namespace

int link_status(const std::string& path, FileStatus& out) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) return -1;
    out = status_of(st);
    return 0;
}

int path_status(const std::string& path, FileStatus& out) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return -1;
    out = status_of(st);
    return 0;
}

int file_identity(const std::string& path, FileIdentity& out) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return -1;
    out = {std::uint64_t(st.st_dev), std::uint64_t(st.st_ino)};
    return 0;
}

int descriptor_status(int fd, FileStatus& out) {
    struct stat st {};
    if (::fstat(fd, &st) != 0) return -1;
    out = status_of(st);
    return 0;
}

int open_file(const std::string& path, unsigned flags, unsigned permissions) {
    int f = (flags & read_write) ? O_RDWR : (flags & write_only) ? O_WRONLY : O_RDONLY;
    if (flags & create) f |= O_CREAT;
    if (flags & truncate) f |= O_TRUNC;
    if (flags & non_blocking) f |= O_NONBLOCK;
    return ::open(path.c_str(), f | O_CLOEXEC, mode_t(permissions));
}

int close_file(int fd) { return ::close(fd); }
int duplicate_descriptor(int fd) { return ::dup(fd); }
int redirect_descriptor(int from, int to) { return ::dup2(from, to); }
long long read_some(int fd, void* buffer, std::size_t bytes) { return ::read(fd, buffer, bytes); }
long long write_some(int fd, const void* buffer, std::size_t bytes) { return ::write(fd, buffer, bytes); }
int make_blocking(int fd) { return ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK); }
int sync_file(int fd) { return ::fsync(fd); }

int sync_path(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return -1;
    const int rc = ::fsync(fd);
    const int err = errno;
    ::close(fd);
    errno = err;
    return rc;
}

void sync_directory(const std::string& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        (void)::fsync(fd);  // best effort: some file systems refuse fsync on directories
        ::close(fd);
    }
}

int set_permissions(int fd, unsigned permissions) { return ::fchmod(fd, mode_t(permissions & 07777)); }
int hard_link(const std::string& existing, const std::string& link) { return ::link(existing.c_str(), link.c_str()); }
int replace_file(const std::string& from, const std::string& to) { return ::rename(from.c_str(), to.c_str()); }
int remove_file(const std::string& path) { return ::unlink(path.c_str()); }
bool can_create_in(const std::string& dir) { return ::access(dir.c_str(), W_OK | X_OK) == 0; }

long max_file_name(const std::string& dir) {
    const long n = ::pathconf(dir.c_str(), _PC_NAME_MAX);
    return n > 0 ? n : NAME_MAX;
}

int read_link(const std::string& path, std::string& target) {
    std::string buf(PATH_MAX + 1, '\0');
    const ssize_t n = ::readlink(path.c_str(), buf.data(), buf.size() - 1);
    if (n < 0) return -1;
    target.assign(buf.data(), std::size_t(n));
    return 0;
}

int resolve_path(const std::string& path, std::string& resolved) {
    char* real = ::realpath(path.c_str(), nullptr);
    if (!real) return -1;
    resolved = real;
    std::free(real);
    return 0;
}

int make_unique_file(std::string& path_template) {
    const int fd = ::mkstemp(path_template.data());
    if (fd >= 0) ::fcntl(fd, F_SETFD, FD_CLOEXEC);
    return fd;
}

int try_lock_exclusive(int fd) {
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return 0;
    return errno == EWOULDBLOCK || errno == EINTR ? 1 : -1;
}

// --- processes -------------------------------------------------------------------------------------

long process_id() { return long(::getpid()); }

bool process_exists(long pid) {
    if (pid <= 0 || pid > INT_MAX) return false;
    return ::kill(pid_t(pid), 0) == 0 || errno != ESRCH;
}

std::string host_name() {
    char name[256] = {};
    if (::gethostname(name, sizeof name - 1) != 0) return "";
    return name;
}

std::string user_tag() { return std::to_string(::getuid()); }
bool is_terminal(int fd) { return ::isatty(fd) == 1; }

std::string executable_path(std::error_code& ec) {
    std::string target;
    if (read_link("/proc/self/exe", target) != 0) {
        ec = std::error_code(errno, std::generic_category());
        return "";
    }
    ec.clear();
    return target;
}

std::vector<std::string> find_on_path(const std::string& name) {
    if (name.find('/') != std::string::npos) return ::access(name.c_str(), X_OK) == 0 ? std::vector<std::string>{name} : std::vector<std::string>{};
    std::vector<std::string> found;
    const char* path = std::getenv("PATH");
    const std::string dirs = path ? path : "/usr/bin:/bin";
    for (std::size_t at = 0; at <= dirs.size();) {
        const std::size_t end = std::min(dirs.find(':', at), dirs.size());
        const std::string dir = end > at ? dirs.substr(at, end - at) : ".";
        const std::string candidate = dir + "/" + name;
        struct stat st {};
        if (::stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(candidate.c_str(), X_OK) == 0)
            found.push_back(candidate);
        at = end + 1;
    }
    return found;
}

ProcessEnd run_program(const std::vector<std::string>& args, const std::function<bool()>& stop) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    // The CLI blocks SIGINT/SIGTERM in every thread (watch_interrupts) and a spawned child inherits that
    // mask: give the child the default mask and dispositions so Ctrl-C stops it too.
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t none, defaults;
    sigemptyset(&none);
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGINT);
    sigaddset(&defaults, SIGTERM);
    sigaddset(&defaults, SIGPIPE);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    pid_t pid = 0;
    const int rc = posix_spawnp(&pid, argv[0], nullptr, &attr, argv.data(), environ);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) throw std::system_error(rc, std::generic_category(), "cannot run " + args[0]);
    int status = 0;
    for (bool signalled = false;;) {
        // Without a question, or once the child has been asked to end: wait for it plainly.
        const pid_t done = ::waitpid(pid, &status, !stop || signalled ? 0 : WNOHANG);
        if (done == pid) break;
        if (done < 0) {
            if (errno == EINTR) continue;
            throw std::system_error(errno, std::generic_category(), "waitpid");
        }
        if (stop()) {
            ::kill(pid, SIGTERM);
            signalled = true;
            continue;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ProcessEnd end;
    end.exited = WIFEXITED(status);
    end.code = end.exited ? WEXITSTATUS(status) : WTERMSIG(status);
    return end;
}


int set_environment(const std::string& name, const std::string& value) {
    return ::setenv(name.c_str(), value.c_str(), 1);
}

int run_shell_command(const std::string& command, std::string& output) {
    FILE* pipe = ::popen(command.c_str(), "r");
    if (!pipe) return -1;
    char buffer[4096];
    while (const std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
    const int status = ::pclose(pipe);
    return status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// --- signals -------------------------------------------------------------------------------------------

bool watch_interrupts(std::function<void(int)> on_interrupt) {
    // Blocked and taken by one thread with sigwait, instead of an asynchronous handler, because a blocked
    // mask is inherited by child processes: PoCL runs its linker as a child while it compiles a kernel,
    // and a terminal's Ctrl-C (sent to the whole process group) killed it mid-link, which made PoCL
    // abort the process instead of stopping cleanly.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    if (pthread_sigmask(SIG_BLOCK, &set, nullptr) != 0) return false;
    std::thread([set, on_interrupt = std::move(on_interrupt)] {
        for (;;) {
            int sig = 0;
            if (sigwait(&set, &sig) != 0) continue;
            on_interrupt(sig == SIGTERM ? kTerminateSignal : kInterruptSignal);
        }
    }).detach();
    return true;
}

namespace {

std::string g_abort_note;  // read by the handler (set before; not changed while it may run)
struct sigaction g_previous_abort {};

extern "C" void write_abort_note(int sig) {
    if (!g_abort_note.empty()) (void)!::write(STDERR_FILENO, g_abort_note.data(), g_abort_note.size());
    ::sigaction(sig, &g_previous_abort, nullptr);  // then die as before: exit status 134
    ::raise(sig);
}

}  // namespace

void set_abort_note(const std::string& note) {
    static std::once_flag once;
    g_abort_note = note;
    std::call_once(once, [] {
        struct sigaction sa {};
        sa.sa_handler = write_abort_note;
        sigemptyset(&sa.sa_mask);
        ::sigaction(SIGABRT, &sa, &g_previous_abort);
    });
}

// --- memory and libraries -------------------------------------------------------------------------

std::uint64_t physical_memory() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? std::uint64_t(pages) * std::uint64_t(page) : 0;
}

void* open_library(const std::string& name, std::string& error) {
    void* handle = ::dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char* why = ::dlerror();
        error = why ? why : "dlopen failed";
    }
    return handle;
}

void* library_symbol(void* library, const char* symbol) { return ::dlsym(library, symbol); }

}  // namespace ms::platform

#endif  // !_WIN32
