#include "io/input_guard.hpp"

#include <map>
#include <mutex>

#include "io/atomic_file.hpp"
#include "platform/files.hpp"

namespace ms {

namespace {

// Process-wide (readers run on worker threads too); guards nest, the outermost one clears the record.
struct NotedInputs {
    std::mutex mutex;
    int guards = 0;
    std::map<platform::FileIdentity, std::string> files;  // identity -> the path it was read as
};

NotedInputs& noted() {
    static NotedInputs n;
    return n;
}

}  // namespace

InputGuard::InputGuard() {
    std::lock_guard<std::mutex> lock(noted().mutex);
    ++noted().guards;
}

InputGuard::~InputGuard() {
    std::lock_guard<std::mutex> lock(noted().mutex);
    if (--noted().guards == 0) noted().files.clear();
}

void note_input(const std::string& path) {
    NotedInputs& n = noted();
    std::lock_guard<std::mutex> lock(n.mutex);
    if (n.guards == 0) return;
    platform::FileIdentity id;
    if (platform::file_identity(path, id) != 0) return;
    n.files.emplace(id, path);
}

void refuse_if_input(const std::string& output, const std::string& named) {
    NotedInputs& n = noted();
    std::lock_guard<std::mutex> lock(n.mutex);
    if (n.guards == 0 || n.files.empty()) return;
    platform::FileIdentity id;
    if (platform::file_identity(output, id) != 0) return;
    const auto it = n.files.find(id);
    if (it == n.files.end()) return;
    throw OutputError("cannot write " + named + ": it is the input " + it->second +
                      " of this command (an output never replaces an input; name another file)");
}

}  // namespace ms
