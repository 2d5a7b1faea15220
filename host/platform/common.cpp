// The parts of the platform layer that are the same everywhere.
#include <cstdlib>

#include "platform/files.hpp"
#include "platform/process.hpp"

namespace ms::platform {

const char* kind_phrase(FileKind kind) {
    switch (kind) {
        case FileKind::regular: return "a regular file";
        case FileKind::directory: return "a directory";
        case FileKind::symlink: return "a symbolic link";
        case FileKind::fifo: return "a FIFO (named pipe)";
        case FileKind::character_device: return "a character device";
        case FileKind::block_device: return "a block device";
        case FileKind::socket: return "a socket";
        case FileKind::missing: return "missing";
        case FileKind::other: break;
    }
    return "not a regular file";
}

void exit_now(int status) { std::_Exit(status); }

}  // namespace ms::platform
