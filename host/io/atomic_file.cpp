#include "io/atomic_file.hpp"

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>

#include "io/input_guard.hpp"
#include "platform/files.hpp"
#include "platform/process.hpp"

namespace ms {

namespace fs = std::filesystem;
using platform::FileKind;

namespace {

std::string sys_error(int err) { return std::strerror(err); }

std::string node_kind(FileKind kind) { return kind == FileKind::regular ? "not a regular file" : platform::kind_phrase(kind); }

// The longest suffix a temporary or backup name adds to the target's name: "." + ".tmp." + a pid
// (pid_max is at most 2^22, 7 digits; 10 leaves room).
constexpr std::size_t kTempNameOverhead = 16;

std::string temp_name(const std::string& path, const char* kind) {
    const fs::path p(path);
    return (p.parent_path() / ("." + p.filename().string() + "." + kind + "." + std::to_string(platform::process_id()))).string();
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
        platform::FileStatus st;
        if (platform::link_status(current, st) != 0) {
            if (errno == ENOENT) return current;
            throw OutputError("cannot write " + named + ": " + current + ": " + sys_error(errno));
        }
        if (st.kind != FileKind::symlink) return current;
        std::string link;
        if (platform::read_link(current, link) != 0)
            throw OutputError("cannot write " + named + ": cannot read the symlink " + current + ": " + sys_error(errno));
        const fs::path target(link);
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
        std::error_code listed;  // an unreadable folder: nothing to clean
        for (fs::directory_iterator e(dir, listed); !listed && e != fs::directory_iterator(); e.increment(listed)) {
            {
                const std::string name = e->path().filename().string();
                if (name.size() < 8 || name[0] != '.') continue;
                const auto dot = name.rfind('.');
                const std::string pid_text = name.substr(dot + 1);
                if (dot < 5 || !is_decimal(pid_text)) continue;
                const std::string kind = name.substr(dot - 4, 5);  // ".tmp." or ".bak."
                if (kind != ".tmp." && kind != ".bak.") continue;
                const long long pid = std::stoll(pid_text);
                if (pid <= 0 || pid > INT_MAX || pid == platform::process_id()) continue;
                if (platform::process_exists(long(pid))) continue;
                stale.push_back(name);
            }
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
        platform::FileStatus st;
        if (platform::link_status(full, st) == 0 && st.kind == FileKind::regular) platform::remove_file(full);
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
            const long long n = platform::write_some(fd_, p, left);
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
        const long long n = platform::write_some(fd, data.data() + done, data.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            err = errno;
            return false;
        }
        done += std::size_t(n);
    }
    return true;
}

void fsync_dir(const std::string& dir) { platform::sync_directory(dir); }

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
    platform::FileStatus st;
    const bool exists = platform::link_status(named, st) == 0;
    if (!exists && errno != ENOENT) {
        if (errno == ENAMETOOLONG) throw OutputError("cannot write " + named + ": file name too long");
        // ENOTDIR: a path component is a file; EACCES: a directory on the way cannot be searched.
        if (errno == ENOTDIR) throw OutputError("cannot write " + named + ": directory " + parent_dir(named) + " does not exist (a component is not a directory)");
        throw OutputError("cannot write " + named + ": " + sys_error(errno));
    }
    t.path = named;
    if (exists && st.kind == FileKind::symlink) {
        platform::FileStatus target;
        if (platform::path_status(named, target) == 0) {
            if (target.kind != FileKind::regular)
                throw OutputError("cannot write " + named + ": it is a symlink to " + node_kind(target.kind) +
                                  "; only regular files are replaced");
            if (platform::resolve_path(named, t.path) != 0)
                throw OutputError("cannot write " + named + ": cannot resolve the symlink: " + sys_error(errno));
        } else if (errno == ENOENT) {
            t.path = follow_links(named);  // dangling: create its target
        } else if (errno == ELOOP) {
            throw OutputError("cannot write " + named + ": symlink loop");
        } else {
            throw OutputError("cannot write " + named + ": " + sys_error(errno));
        }
    } else if (exists) {
        if (st.kind == FileKind::directory) throw OutputError("cannot write " + named + ": it is a directory");
        if (st.kind != FileKind::regular)
            throw OutputError("cannot write " + named + ": it is " + node_kind(st.kind) +
                              "; only regular files are replaced (outputs are written to a temporary file and renamed)");
    }

    const std::string dir = parent_dir(t.path);
    platform::FileStatus dst;
    if (platform::path_status(dir, dst) != 0 || dst.kind != FileKind::directory)
        throw OutputError("cannot write " + named + ": directory " + dir + " does not exist");
    if (!platform::can_create_in(dir))
        throw OutputError("cannot write " + named + ": directory " + dir + " is not writable (" + sys_error(errno) + ")");
    const long name_max = platform::max_file_name(dir);
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
        if (e->fd >= 0) platform::close_file(e->fd);
        e->fd = -1;
        if (!e->temp.empty()) platform::remove_file(e->temp);
    }
}

namespace {
// Whether two output paths name one file. Made absolute first: weakly_canonical of a relative path none
// of whose parts exists stays relative ("s.exr"), while "./s.exr" resolves "." to the working folder.
bool same_file(const fs::path& a, const fs::path& b) {
    std::error_code ec1, ec2, ec3, ec4;
    return fs::weakly_canonical(fs::absolute(a, ec1), ec2) == fs::weakly_canonical(fs::absolute(b, ec3), ec4);
}
}  // namespace

std::size_t OutputSet::add(const std::string& path, bool binary, bool allow_stdout) {
    OutputTarget t = prepare_output(path, allow_stdout);
    for (const auto& e : entries_) {
        if (t.to_stdout && e->target.to_stdout) throw OutputError("two outputs go to standard output");
        if (!t.to_stdout && !e->target.to_stdout && same_file(t.path, e->target.path))
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
        platform::FileStatus st;
        const bool existed = platform::path_status(e.target.path, st) == 0;
        e.fd = platform::open_file(e.temp, platform::write_only | platform::create | platform::truncate, 0666);
        if (e.fd < 0) throw std::runtime_error("cannot create " + e.temp + ": " + sys_error(errno));
        if (existed) platform::set_permissions(e.fd, st.permissions);
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
            fd = platform::open_file(e.temp, platform::read_write);  // written by the caller's writer (OpenEXR, libpng)
            if (fd < 0) fail("cannot reopen " + e.temp + " (for " + e.target.named + "): " + sys_error(errno));
        }
        e.out.reset();
        e.buffer.reset();
        e.fd = -1;
        // ENOSPC and EIO of delayed allocation surface at fsync or close, not at write.
        if (platform::sync_file(fd) != 0) {
            const int err = errno;
            platform::close_file(fd);
            fail("cannot write " + e.target.named + ": fsync of " + e.temp + " failed: " + sys_error(err));
        }
        if (platform::close_file(fd) != 0) fail("cannot write " + e.target.named + ": close of " + e.temp + " failed: " + sys_error(errno));
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
        if (!write_all(platform::kStandardOutput, p.data, err)) throw std::runtime_error("cannot write to standard output: " + sys_error(err));
    }
    std::vector<std::string> backups(pending.size());
    std::vector<bool> existed(pending.size(), false);
    std::set<std::string> dirs;
    for (std::size_t i = 0; i < pending.size(); ++i) {
        const OutputGroup::Pending& e = pending[i];
        if (e.to_stdout) continue;
        platform::FileStatus st;
        if (platform::link_status(e.path, st) == 0) {
            existed[i] = true;
            const std::string bak = temp_name(e.path, "bak");
            platform::remove_file(bak);
            if (st.kind == FileKind::regular && platform::hard_link(e.path, bak) == 0) backups[i] = bak;
        }
        if (platform::replace_file(e.temp, e.path) != 0) {
            const int err = errno;
            std::string lost;
            for (std::size_t j = 0; j < i; ++j) {
                const OutputGroup::Pending& done = pending[j];
                if (done.to_stdout) continue;
                if (!backups[j].empty()) platform::replace_file(backups[j], done.path);
                else if (!existed[j]) platform::remove_file(done.path);
                else lost += " " + done.named;  // no hard link possible here: cannot be put back
            }
            if (!backups[i].empty()) platform::remove_file(backups[i]);
            throw std::runtime_error("cannot rename " + e.temp + " to " + e.path + ": " + sys_error(err) +
                                     (lost.empty() ? "; no output was changed"
                                                   : "; already replaced (the file system refused a backup link):" + lost));
        }
        dirs.insert(parent_dir(e.path));
    }
    for (const auto& b : backups)
        if (!b.empty()) platform::remove_file(b);
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
            if (!p.to_stdout) platform::remove_file(p.temp);
}

OutputGroup* OutputGroup::current() { return current_group; }

void OutputGroup::hand_over(Pending p) {
    if (!p.to_stdout)
        for (const auto& q : pending_) {
            if (!q.to_stdout && same_file(q.path, p.path)) {
                platform::remove_file(p.temp);
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
            if (!p.to_stdout) platform::remove_file(p.temp);
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
