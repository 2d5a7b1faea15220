// The byte form of a work item's result (Integrand::save_item / load_item): numbers copied bit for bit
// in the machine's own representation, so a float read back is the float written. Every process of one
// job runs the same build on the same kind of machine (the spec hash records the version); the store is
// not a file format for other programs.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace ms::schedule {

class ItemWriter {
public:
    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    template <class T>
    void put_vector(const std::vector<T>& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        put(std::uint64_t(v.size()));
        if (!v.empty()) bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
    // Text of any length (its size first).
    void put_string(const std::string& text) {
        put(std::uint64_t(text.size()));
        bytes_ += text;
    }
    std::string take() { return std::move(bytes_); }

private:
    std::string bytes_;
};

// Reads what ItemWriter wrote; throws std::runtime_error naming `what` when the bytes run out or are left over.
class ItemReader {
public:
    // Reads `bytes` in place: they must outlive the reader (a temporary is refused at compile time).
    ItemReader(const std::string& bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}
    ItemReader(std::string&&, std::string) = delete;
    template <class T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        need(sizeof(T));
        T v;
        std::memcpy(&v, bytes_.data() + at_, sizeof v);
        at_ += sizeof v;
        return v;
    }
    // A vector of exactly `expected_size` values, or (allow_empty) none.
    template <class T>
    std::vector<T> get_vector(std::uint64_t expected_size, bool allow_empty = false) {
        const std::uint64_t n = get<std::uint64_t>();
        if (n != expected_size && !(allow_empty && n == 0))
            throw std::runtime_error(what_ + ": holds " + std::to_string(n) + " values, not " + std::to_string(expected_size));
        need(n * sizeof(T));
        std::vector<T> v(n);
        if (n) std::memcpy(v.data(), bytes_.data() + at_, n * sizeof(T));
        at_ += n * sizeof(T);
        return v;
    }
    // What put_string wrote.
    std::string get_string() {
        const std::uint64_t n = get<std::uint64_t>();
        need(n);
        std::string text = bytes_.substr(at_, std::size_t(n));
        at_ += std::size_t(n);
        return text;
    }
    void finish() const {
        if (at_ != bytes_.size()) throw std::runtime_error(what_ + ": " + std::to_string(bytes_.size() - at_) + " bytes left over");
    }

private:
    void need(std::uint64_t n) const {
        if (bytes_.size() - at_ < n) throw std::runtime_error(what_ + ": cut short");
    }
    const std::string& bytes_;
    std::string what_;
    std::size_t at_ = 0;
};

// The values of an item that holds texels of a table of fractions (a LUT slice: rows x columns): a
// store's payload is an input like any other, and anyone can recompute its digest. Texels of a row
// that was computed must be finite fractions in [0, 1] with a finite, non-negative standard error; rows
// left out (a partial bake) hold NaN in both. Returns "" or "values: ..." (ItemCheck's "tag: reason").
inline std::string short_number(double v) {  // %.9g: never DBL_MAX's 309 digits in a message
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", v);
    return buf;
}

template <class RowComputed>
std::string check_fraction_texels(const std::vector<float>& value, const std::vector<float>& error, std::uint32_t rows,
                                  std::uint32_t columns, const RowComputed& row_computed) {
    for (std::uint32_t r = 0; r < rows; ++r) {
        const bool computed = row_computed(r);
        for (std::uint32_t c = 0; c < columns; ++c) {
            const std::size_t k = std::size_t(r) * columns + c;
            const float v = value[k], e = error[k];
            const std::string at = "texel (row " + std::to_string(r) + ", column " + std::to_string(c) + ")";
            if (!computed) {
                if (v == v || e == e) return "values: " + at + " of a row this job leaves out holds a number, not NaN";
                continue;
            }
            if (!(v >= 0.0f && v <= 1.0f)) return "values: " + at + " holds " + short_number(v) + ", not a fraction in [0, 1]";
            if (!(e >= 0.0f && e <= 1.0f)) return "values: " + at + " has standard error " + short_number(e) + ", not in [0, 1]";
        }
    }
    return "";
}

}  // namespace ms::schedule
