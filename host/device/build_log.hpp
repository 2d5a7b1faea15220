// Kernel build diagnostics. PoCL's compiler puts its warnings in the program's build log, but it also
// writes its closing count ("50 warnings generated.") straight to the process's stderr, in the middle
// of a command's output. A build runs with stderr captured: the compiler's lines join the build log,
// which is printed only when asked (the CLI's -v) or when the build fails; any other output written
// meanwhile (another thread's progress) is passed on to stderr when the build ends.
#pragma once

#include <cstdio>
#include <mutex>
#include <string>

namespace ms::ocl {

// Whether every successful kernel build prints its log on stderr (off by default; `microshadow -v`).
void set_show_build_logs(bool show);
bool show_build_logs();

// While alive, file descriptor 2 goes to a temporary file (one capture at a time in the process:
// builds on several devices take turns). finish() restores stderr, passes on what was not the
// compiler's and returns the compiler's lines; the destructor finishes a capture not yet finished.
// When stderr cannot be redirected (no temporary file), nothing is captured and finish() returns "".
class CompilerOutputCapture {
public:
    CompilerOutputCapture();
    ~CompilerOutputCapture();
    CompilerOutputCapture(const CompilerOutputCapture&) = delete;
    CompilerOutputCapture& operator=(const CompilerOutputCapture&) = delete;
    std::string finish();

private:
    std::unique_lock<std::mutex> lock_;
    std::FILE* file_ = nullptr;
    int saved_stderr_ = -1;
};

// True for the compiler's summary lines: "1 warning generated.", "3 warnings and 1 error generated.".
bool is_compiler_count_line(const std::string& line);

}  // namespace ms::ocl
