// The Win32 implementation of the platform layer (MinGW-w64 and MSVC). Paths are UTF-8 in the rest of
// the program and wide strings here; descriptors are the C runtime's (_open), so the callers' read,
// write and close logic is the same as on POSIX.
#ifdef _WIN32

#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#ifndef NOMINMAX
#define NOMINMAX
#endif
#include <windows.h>

#include <fcntl.h>
#include <io.h>
#include <sys/stat.h>

#include <cerrno>
#include <algorithm>
#include <cctype>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <random>
#include <system_error>
#include <string>
#include <thread>
#include <vector>

#include "platform/dynamic_library.hpp"
#include "platform/files.hpp"
#include "platform/memory.hpp"
#include "platform/process.hpp"
#include "platform/signals.hpp"

namespace ms::platform {

namespace {

std::wstring wide(const std::string& utf8) {
    if (utf8.empty()) return {};
    const int n = ::MultiByteToWideChar(CP_UTF8, 0, utf8.data(), int(utf8.size()), nullptr, 0);
    std::wstring out(std::size_t(n > 0 ? n : 0), L'\0');
    if (n > 0) ::MultiByteToWideChar(CP_UTF8, 0, utf8.data(), int(utf8.size()), out.data(), n);
    return out;
}

std::string utf8(const std::wstring& w) {
    if (w.empty()) return {};
    const int n = ::WideCharToMultiByte(CP_UTF8, 0, w.data(), int(w.size()), nullptr, 0, nullptr, nullptr);
    std::string out(std::size_t(n > 0 ? n : 0), '\0');
    if (n > 0) ::WideCharToMultiByte(CP_UTF8, 0, w.data(), int(w.size()), out.data(), n, nullptr, nullptr);
    return out;
}

// errno for the thread's last Win32 error, so every function reports failures as on POSIX.
int fail_with_last_error() {
    switch (::GetLastError()) {
        case ERROR_FILE_NOT_FOUND:
        case ERROR_PATH_NOT_FOUND:
        case ERROR_INVALID_NAME: errno = ENOENT; break;
        case ERROR_ACCESS_DENIED:
        case ERROR_SHARING_VIOLATION: errno = EACCES; break;
        case ERROR_ALREADY_EXISTS:
        case ERROR_FILE_EXISTS: errno = EEXIST; break;
        case ERROR_NOT_SAME_DEVICE: errno = EXDEV; break;
        case ERROR_DISK_FULL: errno = ENOSPC; break;
        case ERROR_FILENAME_EXCED_RANGE: errno = ENAMETOOLONG; break;
        case ERROR_NOT_SUPPORTED:
        case ERROR_INVALID_FUNCTION: errno = ENOSYS; break;
        default: errno = EIO; break;
    }
    return -1;
}

FileStatus status_of(const struct _stat64& st) {
    FileStatus s;
    const unsigned m = unsigned(st.st_mode);
    s.kind = (m & _S_IFMT) == _S_IFREG ? FileKind::regular : (m & _S_IFMT) == _S_IFDIR ? FileKind::directory
           : (m & _S_IFMT) == _S_IFCHR ? FileKind::character_device : (m & _S_IFMT) == _S_IFIFO ? FileKind::fifo
           : FileKind::other;
    s.size = std::uint64_t(st.st_size);
    s.permissions = (m & _S_IWRITE) ? 0666u : 0444u;
    s.owned_by_user = true;
    return s;
}

}  // namespace

int link_status(const std::string& path, FileStatus& out) {
    WIN32_FILE_ATTRIBUTE_DATA data{};
    if (!::GetFileAttributesExW(wide(path).c_str(), GetFileExInfoStandard, &data)) {
        // Devices (NUL, CON) have no attributes: fall back to the runtime's stat.
        return path_status(path, out);
    }
    if (data.dwFileAttributes & FILE_ATTRIBUTE_REPARSE_POINT) {
        out = FileStatus{};
        out.kind = FileKind::symlink;
        return 0;
    }
    return path_status(path, out);
}

int path_status(const std::string& path, FileStatus& out) {
    struct _stat64 st {};
    if (::_wstat64(wide(path).c_str(), &st) != 0) return -1;
    out = status_of(st);
    return 0;
}

int file_identity(const std::string& path, FileIdentity& out) {
    // Opened for no access (attributes only), sharing everything: works on files others hold open.
    HANDLE h = ::CreateFileW(wide(path).c_str(), 0, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, nullptr,
                             OPEN_EXISTING, FILE_FLAG_BACKUP_SEMANTICS, nullptr);
    if (h == INVALID_HANDLE_VALUE) {
        errno = ENOENT;
        return -1;
    }
    BY_HANDLE_FILE_INFORMATION info{};
    const BOOL ok = ::GetFileInformationByHandle(h, &info);
    ::CloseHandle(h);
    if (!ok) {
        errno = EIO;
        return -1;
    }
    out = {std::uint64_t(info.dwVolumeSerialNumber),
           (std::uint64_t(info.nFileIndexHigh) << 32) | std::uint64_t(info.nFileIndexLow)};
    return 0;
}

int descriptor_status(int fd, FileStatus& out) {
    struct _stat64 st {};
    if (::_fstat64(fd, &st) != 0) return -1;
    out = status_of(st);
    return 0;
}

int open_file(const std::string& path, unsigned flags, unsigned permissions) {
    // Windows has no FIFOs among files, so non_blocking needs nothing here.
    int f = (flags & read_write) ? _O_RDWR : (flags & write_only) ? _O_WRONLY : _O_RDONLY;
    if (flags & create) f |= _O_CREAT;
    if (flags & truncate) f |= _O_TRUNC;
    const int mode = (permissions & 0200) ? (_S_IREAD | _S_IWRITE) : _S_IREAD;
    return ::_wopen(wide(path).c_str(), f | _O_BINARY | _O_NOINHERIT, mode);
}

int close_file(int fd) { return ::_close(fd); }
int duplicate_descriptor(int fd) { return ::_dup(fd); }
int redirect_descriptor(int from, int to) { return ::_dup2(from, to); }

long long read_some(int fd, void* buffer, std::size_t bytes) {
    return ::_read(fd, buffer, unsigned(std::min<std::size_t>(bytes, INT_MAX)));
}

long long write_some(int fd, const void* buffer, std::size_t bytes) {
    return ::_write(fd, buffer, unsigned(std::min<std::size_t>(bytes, INT_MAX)));
}

int make_blocking(int) { return 0; }
int sync_file(int fd) { return ::_commit(fd); }
int sync_path(const std::string& path) {
    const HANDLE h = ::CreateFileW(wide(path).c_str(), GENERIC_WRITE, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE,
                                   nullptr, OPEN_EXISTING, FILE_ATTRIBUTE_NORMAL, nullptr);
    if (h == INVALID_HANDLE_VALUE) return fail_with_last_error();
    const bool flushed = ::FlushFileBuffers(h) != 0;
    if (!flushed) fail_with_last_error();
    ::CloseHandle(h);
    return flushed ? 0 : -1;
}

void sync_directory(const std::string&) {}  // NTFS makes a rename durable with the file's own flush

int set_permissions(int, unsigned) { return 0; }  // the rwx bits have no Windows counterpart to keep

int hard_link(const std::string& existing, const std::string& link) {
    return ::CreateHardLinkW(wide(link).c_str(), wide(existing).c_str(), nullptr) ? 0 : fail_with_last_error();
}

int replace_file(const std::string& from, const std::string& to) {
    return ::MoveFileExW(wide(from).c_str(), wide(to).c_str(), MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH)
               ? 0
               : fail_with_last_error();
}

int remove_file(const std::string& path) { return ::_wunlink(wide(path).c_str()); }

bool can_create_in(const std::string& dir) {
    FileStatus s;
    if (path_status(dir, s) != 0) return false;
    if (s.kind != FileKind::directory) {
        errno = ENOTDIR;
        return false;
    }
    // The read-only attribute of a folder does not stop file creation on Windows; ACLs are tried by the
    // write itself, whose error the callers report.
    return ::_waccess(wide(dir).c_str(), 0) == 0;
}

long max_file_name(const std::string&) { return 255; }

int read_link(const std::string& path, std::string& target) {
    std::error_code ec;
    const auto t = std::filesystem::read_symlink(std::filesystem::path(wide(path)), ec);
    if (ec) {
        errno = ec.value() ? EINVAL : EIO;
        return -1;
    }
    target = utf8(t.wstring());
    return 0;
}

int resolve_path(const std::string& path, std::string& resolved) {
    std::error_code ec;
    const auto r = std::filesystem::canonical(std::filesystem::path(wide(path)), ec);
    if (ec) {
        errno = ENOENT;
        return -1;
    }
    resolved = utf8(r.wstring());
    return 0;
}

int make_unique_file(std::string& path_template) {
    const std::size_t at = path_template.rfind("XXXXXX");
    if (at == std::string::npos || at + 6 != path_template.size()) {
        errno = EINVAL;
        return -1;
    }
    static const char letters[] = "abcdefghijklmnopqrstuvwxyz0123456789";
    std::random_device seed;
    std::mt19937 pick(seed());
    for (int attempt = 0; attempt < 100; ++attempt) {
        for (std::size_t k = 0; k < 6; ++k) path_template[at + k] = letters[pick() % (sizeof letters - 1)];
        const int fd = ::_wopen(wide(path_template).c_str(), _O_RDWR | _O_CREAT | _O_EXCL | _O_BINARY | _O_NOINHERIT,
                                _S_IREAD | _S_IWRITE);
        if (fd >= 0 || errno != EEXIST) return fd;
    }
    errno = EEXIST;
    return -1;
}

int try_lock_exclusive(int fd) {
    const HANDLE h = reinterpret_cast<HANDLE>(::_get_osfhandle(fd));
    if (h == INVALID_HANDLE_VALUE) {
        errno = EBADF;
        return -1;
    }
    OVERLAPPED whole{};
    if (::LockFileEx(h, LOCKFILE_EXCLUSIVE_LOCK | LOCKFILE_FAIL_IMMEDIATELY, 0, MAXDWORD, MAXDWORD, &whole)) return 0;
    if (::GetLastError() == ERROR_LOCK_VIOLATION || ::GetLastError() == ERROR_IO_PENDING) return 1;
    return fail_with_last_error();
}

// --- processes -------------------------------------------------------------------------------------

long process_id() { return long(::GetCurrentProcessId()); }

bool process_exists(long pid) {
    if (pid <= 0) return false;
    const HANDLE h = ::OpenProcess(PROCESS_QUERY_LIMITED_INFORMATION, FALSE, DWORD(pid));
    if (!h) return ::GetLastError() != ERROR_INVALID_PARAMETER;  // access denied: it exists
    DWORD code = 0;
    const bool running = ::GetExitCodeProcess(h, &code) && code == STILL_ACTIVE;
    ::CloseHandle(h);
    return running;
}

std::string host_name() {
    wchar_t name[MAX_COMPUTERNAME_LENGTH + 1] = {};
    DWORD size = MAX_COMPUTERNAME_LENGTH + 1;
    return ::GetComputerNameW(name, &size) ? utf8(std::wstring(name, size)) : std::string();
}

std::string user_tag() {
    wchar_t name[257] = {};
    DWORD size = 257;
    std::string tag = ::GetUserNameW(name, &size) && size > 1 ? utf8(std::wstring(name, size - 1)) : "user";
    for (char& c : tag)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) c = '_';
    return tag;
}

bool is_terminal(int fd) { return ::_isatty(fd) != 0; }

std::string executable_path(std::error_code& ec) {
    std::wstring buf(MAX_PATH, L'\0');
    for (;;) {
        const DWORD n = ::GetModuleFileNameW(nullptr, buf.data(), DWORD(buf.size()));
        if (n == 0) {
            ec = std::error_code(int(::GetLastError()), std::system_category());
            return "";
        }
        if (n < buf.size()) {
            buf.resize(n);
            break;
        }
        buf.resize(buf.size() * 2);
    }
    ec.clear();
    return utf8(buf);
}

std::vector<std::string> find_on_path(const std::string& name) {
    namespace fs = std::filesystem;
    std::vector<std::wstring> extensions = {L""};
    if (fs::path(wide(name)).extension().empty()) {
        const wchar_t* pathext = ::_wgetenv(L"PATHEXT");
        const std::wstring list = pathext && *pathext ? pathext : L".COM;.EXE;.BAT;.CMD";
        for (std::size_t at = 0; at <= list.size();) {
            const std::size_t end = std::min(list.find(L';', at), list.size());
            if (end > at) extensions.push_back(list.substr(at, end - at));
            at = end + 1;
        }
    }
    std::error_code ec;
    auto found = [&](const fs::path& base) -> std::string {
        for (const auto& ext : extensions) {
            fs::path candidate = base;
            candidate += ext;
            if (fs::is_regular_file(candidate, ec)) return utf8(candidate.wstring());
        }
        return "";
    };
    std::vector<std::string> all;
    if (name.find_first_of("/\\:") != std::string::npos) {
        const std::string hit = found(fs::path(wide(name)));
        if (!hit.empty()) all.push_back(hit);
        return all;
    }
    const wchar_t* path = ::_wgetenv(L"PATH");
    const std::wstring dirs = path ? path : L"";
    for (std::size_t at = 0; at <= dirs.size();) {
        const std::size_t end = std::min(dirs.find(L';', at), dirs.size());
        if (end > at) {
            const std::string hit = found(fs::path(dirs.substr(at, end - at)) / wide(name));
            if (!hit.empty()) all.push_back(hit);
        }
        at = end + 1;
    }
    return all;
}

namespace {

// One argument quoted so that the C runtime's parser (CommandLineToArgvW's rules) gives it back intact:
// backslashes are literal except before a quote, where they and the quote are escaped.
std::wstring quote_argument(const std::wstring& arg) {
    if (!arg.empty() && arg.find_first_of(L" \t\n\v\"") == std::wstring::npos) return arg;
    std::wstring out = L"\"";
    for (std::size_t i = 0;; ++i) {
        std::size_t backslashes = 0;
        while (i < arg.size() && arg[i] == L'\\') {
            ++i;
            ++backslashes;
        }
        if (i == arg.size()) {
            out.append(backslashes * 2, L'\\');
            break;
        }
        if (arg[i] == L'"') {
            out.append(backslashes * 2 + 1, L'\\');
            out.push_back(L'"');
        } else {
            out.append(backslashes, L'\\');
            out.push_back(arg[i]);
        }
    }
    out.push_back(L'"');
    return out;
}

}  // namespace

ProcessEnd run_program(const std::vector<std::string>& args, const std::function<bool()>& stop) {
    const std::vector<std::string> programs = find_on_path(args.at(0));
    const std::string program = programs.empty() ? std::string() : programs.front();
    if (program.empty())
        throw std::system_error(std::make_error_code(std::errc::no_such_file_or_directory), "cannot run " + args[0]);
    std::wstring command_line;
    for (const auto& a : args) command_line += (command_line.empty() ? L"" : L" ") + quote_argument(wide(a));
    STARTUPINFOW startup{};
    startup.cb = sizeof startup;
    PROCESS_INFORMATION info{};
    // The child shares the console: Ctrl-C reaches it as it reaches us.
    if (!::CreateProcessW(wide(program).c_str(), command_line.data(), nullptr, nullptr, FALSE, 0, nullptr, nullptr,
                          &startup, &info))
        throw std::system_error(int(::GetLastError()), std::system_category(), "cannot run " + args[0]);
    if (!stop) {
        ::WaitForSingleObject(info.hProcess, INFINITE);
    } else {
        while (::WaitForSingleObject(info.hProcess, 50) == WAIT_TIMEOUT)
            if (stop()) {
                ::TerminateProcess(info.hProcess, 1);
                ::WaitForSingleObject(info.hProcess, INFINITE);
                break;
            }
    }
    DWORD code = 0;
    ::GetExitCodeProcess(info.hProcess, &code);
    ::CloseHandle(info.hThread);
    ::CloseHandle(info.hProcess);
    ProcessEnd end;
    end.exited = true;
    end.code = int(code);
    return end;
}

int set_environment(const std::string& name, const std::string& value) {
    return ::_putenv_s(name.c_str(), value.c_str()) == 0 ? 0 : -1;
}

int run_shell_command(const std::string& command, std::string& output) {
    FILE* pipe = ::_wpopen(wide(command).c_str(), L"rb");
    if (!pipe) return -1;
    char buffer[4096];
    while (const std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
    return ::_pclose(pipe);
}

// --- signals -------------------------------------------------------------------------------------------

namespace {

std::function<void(int)>& interrupt_callback() {
    static std::function<void(int)> callback;
    return callback;
}

// Windows runs a console control handler on a new thread of its own, as watch_interrupts promises.
BOOL WINAPI on_console_event(DWORD event) {
    const auto& callback = interrupt_callback();
    if (!callback) return FALSE;
    callback(event == CTRL_C_EVENT ? kInterruptSignal : kTerminateSignal);
    return TRUE;
}

std::string g_abort_note;

extern "C" void write_abort_note(int sig) {
    if (!g_abort_note.empty()) (void)::_write(2, g_abort_note.data(), unsigned(g_abort_note.size()));
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

}  // namespace

bool watch_interrupts(std::function<void(int)> on_interrupt) {
    interrupt_callback() = std::move(on_interrupt);
    return ::SetConsoleCtrlHandler(on_console_event, TRUE) != 0;
}

void set_abort_note(const std::string& note) {
    static std::once_flag once;
    g_abort_note = note;
    std::call_once(once, [] { std::signal(SIGABRT, write_abort_note); });
}

// --- memory and libraries -------------------------------------------------------------------------

std::uint64_t physical_memory() {
    MEMORYSTATUSEX status{};
    status.dwLength = sizeof status;
    return ::GlobalMemoryStatusEx(&status) ? std::uint64_t(status.ullTotalPhys) : 0;
}

void* open_library(const std::string& name, std::string& error) {
    HMODULE handle = ::LoadLibraryW(wide(name).c_str());
    if (!handle) error = "LoadLibrary failed (Windows error " + std::to_string(::GetLastError()) + ")";
    return reinterpret_cast<void*>(handle);
}

void* library_symbol(void* library, const char* symbol) {
    return reinterpret_cast<void*>(::GetProcAddress(static_cast<HMODULE>(library), symbol));
}

}  // namespace ms::platform

#endif  // _WIN32
