// Files that appear only when complete: written to a temporary file beside the target, every write
// checked, flushed to disk, then renamed over it. A crash or kill at any moment leaves the previous
// file intact (and the stale temporary is removed by the next run that writes the same output).
//
// What an output path means (prepare_output):
//   - a regular file or a new name: replaced by rename;
//   - a symlink: followed to its final target, which is replaced; the link itself is kept;
//   - "-" (only where a command allows it: CSV results): standard output, written once complete;
//   - anything else that exists (a directory, a character or block device such as /dev/null or
//     /dev/full, a FIFO, a socket): refused before any work, since a rename would replace the node;
//   - the directory must exist and be writable, and the temporary names beside the target must fit
//     the file system's NAME_MAX (a target name of at most NAME_MAX - 16 bytes).
// Every refusal is an OutputError (an std::invalid_argument: bad input, exit status 2 in the CLI).
#pragma once

#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace ms {

class OutputError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

// A checked output destination.
struct OutputTarget {
    std::string named;       // as given
    std::string path;        // the file to replace: `named`, or the final target of its symlinks
    bool to_stdout = false;  // "-"
};

// Checks and resolves an output path as described above, and removes stale temporaries of this target
// (.NAME.tmp.PID or .NAME.bak.PID whose process no longer exists). Throws OutputError.
OutputTarget prepare_output(const std::string& path, bool allow_stdout = false);

// prepare_output(path) for callers that only want the check (kept for existing callers).
void check_writable_destination(const std::string& path);

// Several outputs that appear together or not at all (a CSV and its .json sidecar): every path is
// checked when added (call add() before the long computation), each is written to its temporary,
// then commit() checks and syncs all temporaries before renaming any of them; a failing rename puts
// the previous files back. The destructor removes temporaries of an uncommitted set.
class OutputSet {
public:
    OutputSet() = default;
    ~OutputSet();
    OutputSet(const OutputSet&) = delete;
    OutputSet& operator=(const OutputSet&) = delete;

    // Returns the index for stream(). allow_stdout: "-" means standard output. Throws OutputError
    // (also when two entries resolve to the same file).
    std::size_t add(const std::string& path, bool binary = false, bool allow_stdout = false);
    bool to_stdout(std::size_t index) const { return entries_.at(index)->target.to_stdout; }
    const OutputTarget& target(std::size_t index) const { return entries_.at(index)->target; }
    // The stream of entry `index` (its temporary file is created on the first call).
    std::ostream& stream(std::size_t index);
    // For writers that need a path (OpenEXR, libpng): the temporary to write, renamed by commit().
    std::string temp_path(std::size_t index);
    // Throws std::runtime_error naming the file and the system error (ENOSPC, EIO, ...); then nothing
    // is replaced and no temporary is left.
    void commit();

private:
    struct Entry {
        OutputTarget target;
        bool binary = false;
        std::string temp;
        bool opened = false;  // temp created (by stream() or by the caller's writer)
        int fd = -1;          // stream(): the temporary, written through a checked buffer
        std::unique_ptr<std::streambuf> buffer;
        std::unique_ptr<std::ostream> out;
        std::ostringstream memory;  // standard output: written at commit, after the files are ready
    };
    void discard();
    std::vector<std::unique_ptr<Entry>> entries_;
    bool committed_ = false;
};

// Several writers' outputs made one set. Writers that commit their own files (an AtomicFile, an
// AtomicPath, an OutputSet: a preview, a shader, a LUT in its format) do so in turn; while an
// OutputGroup is open on this thread, each of those commits completes and syncs its temporaries (so a
// full disk, ENOSPC, is found there) and hands them to the group instead of renaming them. The
// group's commit() then renames all of them as one set (putting every previous file back if a rename
// fails); a group destroyed uncommitted (an exception, a cancel) removes them and changes nothing.
// A group opened inside another joins it: the outermost one commits.
class OutputGroup {
public:
    OutputGroup();
    ~OutputGroup();
    OutputGroup(const OutputGroup&) = delete;
    OutputGroup& operator=(const OutputGroup&) = delete;
    // Throws std::runtime_error as OutputSet::commit() does.
    void commit();

    // Internal (OutputSet::commit): a completed temporary to rename at the group's commit, or data for
    // standard output. Throws OutputError when the group already holds an output to the same file.
    struct Pending {
        std::string temp, path, named;
        bool to_stdout = false;
        std::string data;
    };
    static OutputGroup* current();
    void hand_over(Pending pending);

private:
    OutputGroup* outer_ = nullptr;  // the group this one joined, if any
    std::vector<Pending> pending_;
    bool committed_ = false;
};

// One output, for callers that write a single file.
class AtomicFile {
public:
    explicit AtomicFile(std::string path, bool binary = false);
    std::ostream& stream() { return set_.stream(0); }
    std::string temp_path() { return set_.temp_path(0); }
    void commit() { set_.commit(); }

private:
    OutputSet set_;
};

// For writers that need a path (OpenEXR, libpng): write to temp_path(), then commit().
class AtomicPath {
public:
    explicit AtomicPath(std::string path);
    const std::string& temp_path() const { return temp_; }
    void commit() { set_.commit(); }

private:
    OutputSet set_;
    std::string temp_;
};

}  // namespace ms
