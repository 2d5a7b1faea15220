// Whether this build runs under AddressSanitizer (gcc defines __SANITIZE_ADDRESS__, clang answers
// __has_feature): the tests that cap the CLI's memory with ulimit skip there, since the sanitizer's
// shadow memory reserves terabytes of address space.
#pragma once

namespace ms::testing {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAsan = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAsan = true;
#else
inline constexpr bool kAsan = false;
#endif
#else
inline constexpr bool kAsan = false;
#endif

}  // namespace ms::testing
