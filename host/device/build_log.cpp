#include "device/build_log.hpp"

#include "platform/files.hpp"

#include <atomic>
#include <regex>

namespace ms::ocl {

namespace {

std::atomic<bool>& show_flag() {
    static std::atomic<bool> show{false};
    return show;
}

std::mutex& capture_mutex() {
    static std::mutex m;
    return m;
}

void write_all(int fd, const std::string& text) {
    for (std::size_t done = 0; done < text.size();) {
        const long long n = platform::write_some(fd, text.data() + done, text.size() - done);
        if (n <= 0) return;
        done += std::size_t(n);
    }
}

}  // namespace

void set_show_build_logs(bool show) { show_flag().store(show); }
bool show_build_logs() { return show_flag().load(); }

bool is_compiler_count_line(const std::string& line) {
    static const std::regex count(R"(^\d+ (warnings?|errors?)( and \d+ (warnings?|errors?))? generated\.\s*$)");
    return std::regex_match(line, count);
}

CompilerOutputCapture::CompilerOutputCapture() : lock_(capture_mutex()) {
    std::fflush(stderr);
    file_ = std::tmpfile();
    if (!file_) return;
    saved_stderr_ = platform::duplicate_descriptor(platform::kStandardError);
    if (saved_stderr_ < 0 || platform::redirect_descriptor(fileno(file_), platform::kStandardError) < 0) {
        if (saved_stderr_ >= 0) platform::close_file(saved_stderr_);
        saved_stderr_ = -1;
        std::fclose(file_);
        file_ = nullptr;
    }
}

CompilerOutputCapture::~CompilerOutputCapture() { finish(); }

std::string CompilerOutputCapture::finish() {
    if (!file_) {
        if (lock_.owns_lock()) lock_.unlock();
        return {};
    }
    std::fflush(stderr);
    platform::redirect_descriptor(saved_stderr_, platform::kStandardError);
    platform::close_file(saved_stderr_);
    saved_stderr_ = -1;
    std::string text;
    std::rewind(file_);
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, file_)) > 0;) text.append(buf, n);
    std::fclose(file_);
    file_ = nullptr;
    // Line by line: the compiler's count lines are kept, the rest goes to stderr as it was written.
    std::string compiler, others;
    for (std::size_t at = 0; at < text.size();) {
        std::size_t end = text.find('\n', at);
        end = end == std::string::npos ? text.size() : end + 1;
        const std::string line = text.substr(at, end - at);
        std::string bare = line;
        while (!bare.empty() && (bare.back() == '\n' || bare.back() == '\r')) bare.pop_back();
        (is_compiler_count_line(bare) ? compiler : others) += line;
        at = end;
    }
    write_all(platform::kStandardError, others);
    lock_.unlock();
    return compiler;
}

}  // namespace ms::ocl
