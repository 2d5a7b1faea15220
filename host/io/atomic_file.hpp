// Files that appear only when complete: written to a temporary file beside the target, flushed to
// disk, then renamed over it. A crash or kill at any moment leaves the previous file intact.
#pragma once

#include <fstream>
#include <string>

namespace ms {

class AtomicFile {
public:
    explicit AtomicFile(std::string path, bool binary = false);
    ~AtomicFile();  // removes the temporary file unless commit() succeeded
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    std::ofstream& stream() { return out_; }
    const std::string& temp_path() const { return temp_; }
    // Flushes, fsyncs and renames the temporary file onto the target. Throws std::runtime_error.
    void commit();

private:
    std::string path_, temp_;
    std::ofstream out_;
    bool committed_ = false;
};

// For writers that need a path (OpenEXR, libpng): write to temp_path(), then commit_path().
class AtomicPath {
public:
    explicit AtomicPath(std::string path);
    ~AtomicPath();
    const std::string& temp_path() const { return temp_; }
    void commit();

private:
    std::string path_, temp_;
    bool committed_ = false;
};

// Throws std::runtime_error with a clear message if `path`'s directory does not exist or is not writable.
void check_writable_destination(const std::string& path);

}  // namespace ms
