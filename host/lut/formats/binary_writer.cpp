#include "lut/formats/binary_writer.hpp"

#include <stdexcept>

#include "io/atomic_file.hpp"

namespace ms::lutfmt {

void write_file_atomically(const std::string& path, const std::vector<std::uint8_t>& bytes) {
    AtomicFile file(path, true);
    file.stream().write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!file.stream()) throw std::runtime_error("cannot write " + path);
    file.commit();
}

void write_text_atomically(const std::string& path, const std::string& text) {
    AtomicFile file(path, true);
    file.stream() << text;
    if (!file.stream()) throw std::runtime_error("cannot write " + path);
    file.commit();
}

}  // namespace ms::lutfmt
