#include "io/atomic_file.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>

#include "io/input_guard.hpp"

namespace ms {

namespace fs = std::filesystem;

namespace {

std::string sys_error(int err) { return std::strerror(err); }

std::string node_kind(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

// The longest suffix a temporary or backup name adds to the target's name: "." + ".tmp." + a pid
// (pid_max is at most 2^22, 7 digits; 10 leaves room).
constexpr std::size_t kTempNameOverhead = 16;

std::string temp_name(const std::string& path, const char* kind) {
    const fs::path p(path);
    return (p.parent_path() / ("." + p.filename().string() + "." + kind + "." + std::to_string(::getpid()))).string();
}

std::string parent_dir(const std::string& path) {
    const std::string d = fs::path(path).parent_path().string();
    return d.empty() ? "." : d;
}

// Follows a chain of symlinks whose end may not exist yet (a dangling link names the file to create,
// as the shell's '>' would). Returns the final path.
std::string follow_links(const std::string& named) {
    std::string current = named;
    for (int hop = 0; hop < 40; ++hop) {
        struct stat st {};
        if (::lstat(current.c_str(), &st) != 0) {
            if (errno == ENOENT) return current;
            throw OutputError("cannot write " + named + ": " + current + ": " + sys_error(errno));
        }
        if (!S_ISLNK(st.st_mode)) return current;
        std::vector<char> buf(PATH_MAX + 1);
        const ssize_t n = ::readlink(current.c_str(), buf.data(), buf.size() - 1);
        if (n < 0) throw OutputError("cannot write " + named + ": cannot read the symlink " + current + ": " + sys_error(errno));
        const fs::path target(std::string(buf.data(), std::size_t(n)));
        current = target.is_absolute() ? target.string() : (fs::path(parent_dir(current)) / target).lexically_normal().string();
    }
    throw OutputError("cannot write " + named + ": too many levels of symbolic links");
}

bool is_decimal(const std::string& s) {
    if (s.empty() || s.size() > 10) return false;
    for (char c : s)
        if (c < '0' || c > '9') return false;
    return true;
}

// A temporary of a run that was killed (kill -9, power loss) is never removed by that run; the next
// run that writes the same output removes it once its process is gone. A live process with that pid
// (possibly an unrelated one that reused it) keeps it: a stale file is harmless, a deleted one is not.
// Each directory is listed once per process (a sweep writes thousands of chunk files into one
// directory; listing it for each would be quadratic): the listing keeps the names that look like our
// temporaries of dead processes, and each output removes those of its own name.
void remove_stale_temporaries(const std::string& path) {
    static std::mutex mutex;
    static std::map<std::string, std::vector<std::string>> stale_by_dir;
    const std::string dir = parent_dir(path);
    const std::string base = "." + fs::path(path).filename().string() + ".";
    std::lock_guard<std::mutex> lock(mutex);
    auto it = stale_by_dir.find(dir);
    if (it == stale_by_dir.end()) {
        std::vector<std::string> stale;
        if (DIR* d = ::opendir(dir.c_str())) {
            while (const dirent* e = ::readdir(d)) {
                const std::string name = e->d_name;
                if (name.size() < 8 || name[0] != '.') continue;
                const auto dot = name.rfind('.');
                const std::string pid_text = name.substr(dot + 1);
                if (dot < 5 || !is_decimal(pid_text)) continue;
                const std::string kind = name.substr(dot - 4, 5);  // ".tmp." or ".bak."
                if (kind != ".tmp." && kind != ".bak.") continue;
                const long long pid = std::stoll(pid_text);
                if (pid <= 0 || pid > INT_MAX || pid == ::getpid()) continue;
                if (::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;
                stale.push_back(name);
            }
            ::closedir(d);
        }
        it = stale_by_dir.emplace(dir, std::move(stale)).first;
    }
    auto& names = it->second;
    for (auto n = names.begin(); n != names.end();) {
        // Exactly ".NAME.tmp.PID" or ".NAME.bak.PID" of this output (not of "NAME.json" when NAME is asked).
        const bool ours = n->size() > base.size() + 4 && n->compare(0, base.size(), base) == 0 &&
                          (n->compare(base.size(), 4, "tmp.") == 0 || n->compare(base.size(), 4, "bak.") == 0) &&
                          is_decimal(n->substr(base.size() + 4));
        if (!ours) {
            ++n;
            continue;
        }
        const std::string full = (fs::path(dir) / *n).string();
        struct stat st {};
        if (::lstat(full.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::unlink(full.c_str());
        n = names.erase(n);
    }
}

bool names_standard_output(const std::string& p) {
    return p == "-" || p == "/dev/stdout" || p == "/dev/fd/1" || p == "/proc/self/fd/1";
}

// A std::streambuf over a file descriptor that keeps the first write error (errno), so a full disk
// (ENOSPC), a file size limit (EFBIG) or an I/O error is reported with its cause, not as a bare
// "write failed" from an ofstream's badbit.
class FdBuf : public std::streambuf {
public:
    explicit FdBuf(int fd) : fd_(fd), buffer_(1 << 16) { setp(buffer_.data(), buffer_.data() + buffer_.size()); }
    int error() const { return error_; }
    bool flush_all() { return drain() && error_ == 0; }

protected:
    int_type overflow(int_type ch) override {
        if (!drain()) return traits_type::eof();
        if (!traits_type::eq_int_type(ch, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(ch);
            pbump(1);
        }
        return traits_type::not_eof(ch);
    }
    int sync() override { return drain() ? 0 : -1; }

private:
    bool drain() {
        const char* p = pbase();
        std::size_t left = std::size_t(pptr() - pbase());
        while (left > 0 && error_ == 0) {
            const ssize_t n = ::write(fd_, p, left);
            if (n < 0) {
                if (errno == EINTR) continue;
                error_ = errno;
            } else {
                p += n;
                left -= std::size_t(n);
            }
        }
        setp(buffer_.data(), buffer_.data() + buffer_.size());
        return error_ == 0;
    }
    int fd_;
    int error_ = 0;
    std::vector<char> buffer_;
};

bool write_all(int fd, const std::string& data, int& err) {
    std::size_t done = 0;
    while (done < data.size()) {
        const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            err = errno;
            return false;
        }
        done += std::size_t(n);
    }
    return true;
}

void fsync_dir(const std::string& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        ::fsync(fd);  // best effort: some file systems refuse fsync on directories
        ::close(fd);
    }
}

}  // namespace

OutputTarget prepare_output(const std::string& named, bool allow_stdout) {
    if (named.empty()) throw OutputError("empty output path");
    OutputTarget t;
    t.named = named;
    if (names_standard_output(named) || named.rfind("/dev/fd/", 0) == 0 || named.rfind("/proc/self/fd/", 0) == 0) {
        if (allow_stdout && names_standard_output(named)) {
            t.to_stdout = true;
            return t;
        }
        throw OutputError("cannot write " + named + ": this output must be a file" +
                          (allow_stdout ? " (use - for standard output)" : " (standard output is not supported here)"));
    }
    struct stat st {};
    const bool exists = ::lstat(named.c_str(), &st) == 0;
    if (!exists && errno != ENOENT) {
        if (errno == ENAMETOOLONG) throw OutputError("cannot write " + named + ": file name too long");
        // ENOTDIR: a path component is a file; EACCES: a directory on the way cannot be searched.
        if (errno == ENOTDIR) throw OutputError("cannot write " + named + ": directory " + parent_dir(named) + " does not exist (a component is not a directory)");
        throw OutputError("cannot write " + named + ": " + sys_error(errno));
    }
    t.path = named;
    if (S_ISLNK(st.st_mode)) {
        struct stat target {};
        if (::stat(named.c_str(), &target) == 0) {
            if (!S_ISREG(target.st_mode))
                throw OutputError("cannot write " + named + ": it is a symlink to " + node_kind(target.st_mode) +
                                  "; only regular files are replaced");
            char* real = ::realpath(named.c_str(), nullptr);
            if (!real) throw OutputError("cannot write " + named + ": cannot resolve the symlink: " + sys_error(errno));
            t.path = real;
            std::free(real);
        } else if (errno == ENOENT) {
            t.path = follow_links(named);  // dangling: create its target
        } else if (errno == ELOOP) {
            throw OutputError("cannot write " + named + ": symlink loop");
        } else {
            throw OutputError("cannot write " + named + ": " + sys_error(errno));
        }
    } else if (exists) {
        if (S_ISDIR(st.st_mode)) throw OutputError("cannot write " + named + ": it is a directory");
        if (!S_ISREG(st.st_mode))
            throw OutputError("cannot write " + named + ": it is " + node_kind(st.st_mode) +
                              "; only regular files are replaced (outputs are written to a temporary file and renamed)");
    }

    const std::string dir = parent_dir(t.path);
    struct stat dst {};
    if (::stat(dir.c_str(), &dst) != 0 || !S_ISDIR(dst.st_mode))
        throw OutputError("cannot write " + named + ": directory " + dir + " does not exist");
    if (::access(dir.c_str(), W_OK) != 0)
        throw OutputError("cannot write " + named + ": directory " + dir + " is not writable (" + sys_error(errno) + ")");
    long name_max = ::pathconf(dir.c_str(), _PC_NAME_MAX);
    if (name_max <= 0) name_max = NAME_MAX;
    const std::string file = fs::path(t.path).filename().string();
    if (file.empty() || file == "." || file == "..") throw OutputError("cannot write " + named + ": not a file name");
    if (file.size() + kTempNameOverhead > std::size_t(name_max))
        throw OutputError("cannot write " + named + ": the file name is " + std::to_string(file.size()) +
                          " bytes; at most " + std::to_string(name_max - long(kTempNameOverhead)) +
                          " fit (NAME_MAX " + std::to_string(name_max) + " less " + std::to_string(kTempNameOverhead) +
                          " for the temporary name ." + "NAME.tmp.PID)");
    refuse_if_input(t.path, named);
    remove_stale_temporaries(t.path);
    return t;
}

void check_writable_destination(const std::string& path) { prepare_output(path, false); }

// --- OutputSet -----------------------------------------------------------------------------------

namespace {
void publish_pending(const std::vector<OutputGroup::Pending>& pending);
thread_local OutputGroup* current_group = nullptr;
}  // namespace

OutputSet::~OutputSet() {
    if (!committed_) discard();
}

void OutputSet::discard() {
    for (auto& e : entries_) {
        e->out.reset();
        e->buffer.reset();
        if (e->fd >= 0) ::close(e->fd);
        e->fd = -1;
        if (!e->temp.empty()) ::unlink(e->temp.c_str());
    }
}

std::size_t OutputSet::add(const std::string& path, bool binary, bool allow_stdout) {
    OutputTarget t = prepare_output(path, allow_stdout);
    for (const auto& e : entries_) {
        if (t.to_stdout && e->target.to_stdout) throw OutputError("two outputs go to standard output");
        std::error_code ec1, ec2;
        if (!t.to_stdout && !e->target.to_stdout &&
            fs::weakly_canonical(t.path, ec1) == fs::weakly_canonical(e->target.path, ec2))
            throw OutputError("outputs " + e->target.named + " and " + path + " name the same file");
    }
    auto e = std::make_unique<Entry>();
    e->target = std::move(t);
    e->binary = binary;
    if (!e->target.to_stdout) e->temp = temp_name(e->target.path, "tmp");
    entries_.push_back(std::move(e));
    return entries_.size() - 1;
}

std::ostream& OutputSet::stream(std::size_t index) {
    Entry& e = *entries_.at(index);
    if (e.target.to_stdout) return e.memory;
    if (!e.opened) {
        // A replaced file keeps its permission bits (a new one gets 0666 less the umask).
        struct stat st {};
        const bool existed = ::stat(e.target.path.c_str(), &st) == 0;
        e.fd = ::open(e.temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
        if (e.fd < 0) throw std::runtime_error("cannot create " + e.temp + ": " + sys_error(errno));
        if (existed) ::fchmod(e.fd, st.st_mode & 07777);
        e.buffer = std::make_unique<FdBuf>(e.fd);
        e.out = std::make_unique<std::ostream>(e.buffer.get());
        e.opened = true;
    }
    return *e.out;
}

std::string OutputSet::temp_path(std::size_t index) {
    Entry& e = *entries_.at(index);
    if (e.target.to_stdout) throw std::logic_error("OutputSet::temp_path: standard output has no path");
    e.opened = true;  // the caller's writer creates it
    return e.temp;
}

void OutputSet::commit() {
    if (committed_) return;
    auto fail = [&](const std::string& what) {
        discard();
        throw std::runtime_error(what);
    };
    // 1. Every temporary complete and on disk before anything is renamed: each write, the fsync and
    //    the close are checked, with their errno (ENOSPC, EFBIG, EIO).
    for (std::size_t i = 0; i < entries_.size(); ++i) {
        Entry& e = *entries_[i];
        if (e.target.to_stdout) continue;
        if (!e.opened) stream(i);  // an output never written: an empty file
        int fd = e.fd;
        if (fd >= 0) {
            auto* buf = static_cast<FdBuf*>(e.buffer.get());
            if (!buf->flush_all()) fail("cannot write " + e.target.named + " (temporary " + e.temp + "): " + sys_error(buf->error()));
        } else {
            fd = ::open(e.temp.c_str(), O_RDWR | O_CLOEXEC);  // written by the caller's writer (OpenEXR, libpng)
            if (fd < 0) fail("cannot reopen " + e.temp + " (for " + e.target.named + "): " + sys_error(errno));
        }
        e.out.reset();
        e.buffer.reset();
        e.fd = -1;
        // ENOSPC and EIO of delayed allocation surface at fsync or close, not at write.
        if (::fsync(fd) != 0) {
            const int err = errno;
            ::close(fd);
            fail("cannot write " + e.target.named + ": fsync of " + e.temp + " failed: " + sys_error(err));
        }
        if (::close(fd) != 0) fail("cannot write " + e.target.named + ": close of " + e.temp + " failed: " + sys_error(errno));
    }
    // 2. Inside an OutputGroup: the group renames these with the other writers' files.
    if (OutputGroup* group = OutputGroup::current()) {
        for (auto& e : entries_) {
            OutputGroup::Pending p;
            p.to_stdout = e->target.to_stdout;
            if (p.to_stdout) p.data = e->memory.str();
            else p.temp = e->temp, p.path = e->target.path, p.named = e->target.named;
            try {
                group->hand_over(std::move(p));
            } catch (...) {
                discard();
                throw;
            }
            e->temp.clear();  // the group removes it if it is not committed
        }
        committed_ = true;
        return;
    }
    std::vector<OutputGroup::Pending> pending;
    for (auto& e : entries_) {
        OutputGroup::Pending p;
        p.to_stdout = e->target.to_stdout;
        if (p.to_stdout) p.data = e->memory.str();
        else p.temp = e->temp, p.path = e->target.path, p.named = e->target.named;
        pending.push_back(std::move(p));
    }
    try {
        publish_pending(pending);
    } catch (...) {
        discard();
        throw;
    }
    for (auto& e : entries_) e->temp.clear();
    committed_ = true;
}

namespace {

// Standard output first (it cannot be taken back, so only once every file is ready), then the renames,
// with a hard-linked backup of each previous file so a failure part-way puts every output back as it
// was (all files or none). The caller removes the temporaries when this throws.
void publish_pending(const std::vector<OutputGroup::Pending>& pending) {
    // An input read after its output was checked (io/input_guard.hpp): refused before anything changes.
    for (const auto& p : pending)
        if (!p.to_stdout) refuse_if_input(p.path, p.named);
    for (const auto& p : pending) {
        if (!p.to_stdout) continue;
        std::fflush(stdout);
        int err = 0;
        if (!write_all(STDOUT_FILENO, p.data, err)) throw std::runtime_error("cannot write to standard output: " + sys_error(err));
    }
    std::vector<std::string> backups(pending.size());
    std::vector<bool> existed(pending.size(), false);
    std::set<std::string> dirs;
    for (std::size_t i = 0; i < pending.size(); ++i) {
        const OutputGroup::Pending& e = pending[i];
        if (e.to_stdout) continue;
        struct stat st {};
        if (::lstat(e.path.c_str(), &st) == 0) {
            existed[i] = true;
            const std::string bak = temp_name(e.path, "bak");
            ::unlink(bak.c_str());
            if (S_ISREG(st.st_mode) && ::link(e.path.c_str(), bak.c_str()) == 0) backups[i] = bak;
        }
        if (std::rename(e.temp.c_str(), e.path.c_str()) != 0) {
            const int err = errno;
            std::string lost;
            for (std::size_t j = 0; j < i; ++j) {
                const OutputGroup::Pending& done = pending[j];
                if (done.to_stdout) continue;
                if (!backups[j].empty()) std::rename(backups[j].c_str(), done.path.c_str());
                else if (!existed[j]) ::unlink(done.path.c_str());
                else lost += " " + done.named;  // no hard link possible here: cannot be put back
            }
            if (!backups[i].empty()) ::unlink(backups[i].c_str());
            throw std::runtime_error("cannot rename " + e.temp + " to " + e.path + ": " + sys_error(err) +
                                     (lost.empty() ? "; no output was changed"
                                                   : "; already replaced (the file system refused a backup link):" + lost));
        }
        dirs.insert(parent_dir(e.path));
    }
    for (const auto& b : backups)
        if (!b.empty()) ::unlink(b.c_str());
    // Make the renames durable.
    for (const auto& d : dirs) fsync_dir(d);
}

}  // namespace

// --- OutputGroup ---------------------------------------------------------------------------------

OutputGroup::OutputGroup() : outer_(current_group) {
    if (!outer_) current_group = this;
}

OutputGroup::~OutputGroup() {
    if (outer_) return;  // joined: the outer group owns the files
    current_group = nullptr;
    if (!committed_)
        for (const auto& p : pending_)
            if (!p.to_stdout) ::unlink(p.temp.c_str());
}

OutputGroup* OutputGroup::current() { return current_group; }

void OutputGroup::hand_over(Pending p) {
    if (!p.to_stdout)
        for (const auto& q : pending_) {
            std::error_code e1, e2;
            if (!q.to_stdout && fs::weakly_canonical(q.path, e1) == fs::weakly_canonical(p.path, e2)) {
                ::unlink(p.temp.c_str());
                throw OutputError("outputs " + q.named + " and " + p.named + " name the same file");
            }
        }
    pending_.push_back(std::move(p));
}

void OutputGroup::commit() {
    if (outer_ || committed_) return;
    current_group = nullptr;  // the renames are this group's own
    try {
        publish_pending(pending_);
    } catch (...) {
        for (const auto& p : pending_)
            if (!p.to_stdout) ::unlink(p.temp.c_str());
        pending_.clear();
        throw;
    }
    committed_ = true;
}

AtomicFile::AtomicFile(std::string path, bool binary) { set_.add(path, binary); }

AtomicPath::AtomicPath(std::string path) {
    set_.add(path);
    temp_ = set_.temp_path(0);
}

}  // namespace ms
