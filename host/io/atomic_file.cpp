#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace ms {

namespace {

std::string make_temp_name(const std::string& path) {
    const std::filesystem::path p(path);
    return (p.parent_path() / ("." + p.filename().string() + ".tmp." + std::to_string(::getpid()))).string();
}

void fsync_file(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY);
    if (fd < 0) throw std::runtime_error("cannot reopen " + path + ": " + std::strerror(errno));
    const int rc = ::fsync(fd);
    ::close(fd);
    if (rc != 0) throw std::runtime_error("fsync failed on " + path + ": " + std::strerror(errno));
}

void rename_into_place(const std::string& temp, const std::string& path) {
    fsync_file(temp);
    if (std::rename(temp.c_str(), path.c_str()) != 0)
        throw std::runtime_error("cannot rename " + temp + " to " + path + ": " + std::strerror(errno));
    // Make the rename itself durable.
    const std::string dir = std::filesystem::path(path).parent_path().string();
    const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
}

}  // namespace

void check_writable_destination(const std::string& path) {
    if (path.empty()) throw std::runtime_error("empty output path");
    const std::filesystem::path p(path);
    const std::filesystem::path dir = p.parent_path().empty() ? std::filesystem::path(".") : p.parent_path();
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
        throw std::runtime_error("cannot write " + path + ": directory " + dir.string() + " does not exist");
    if (std::filesystem::is_directory(p, ec)) throw std::runtime_error("cannot write " + path + ": it is a directory");
    if (::access(dir.c_str(), W_OK) != 0) throw std::runtime_error("cannot write " + path + ": directory not writable");
}

AtomicFile::AtomicFile(std::string path, bool binary) : path_(std::move(path)), temp_(make_temp_name(path_)) {
    check_writable_destination(path_);
    out_.open(temp_, binary ? std::ios::binary | std::ios::trunc : std::ios::trunc);
    if (!out_) throw std::runtime_error("cannot create " + temp_ + ": " + std::strerror(errno));
}

AtomicFile::~AtomicFile() {
    if (!committed_) {
        out_.close();
        std::remove(temp_.c_str());
    }
}

void AtomicFile::commit() {
    out_.flush();
    if (!out_) throw std::runtime_error("write to " + temp_ + " failed");
    out_.close();
    rename_into_place(temp_, path_);
    committed_ = true;
}

AtomicPath::AtomicPath(std::string path) : path_(std::move(path)), temp_(make_temp_name(path_)) {
    check_writable_destination(path_);
}

AtomicPath::~AtomicPath() {
    if (!committed_) std::remove(temp_.c_str());
}

void AtomicPath::commit() {
    rename_into_place(temp_, path_);
    committed_ = true;
}

}  // namespace ms
