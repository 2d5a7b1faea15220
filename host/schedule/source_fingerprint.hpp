// A fingerprint of the sources that decide results' bits (host/ and kernels/, hashed at build time by
// cmake/SourceFingerprint.cmake): two builds share it exactly when they compile the same code. The
// version number alone stays the same across such changes (a kernel's rounding, a quadrature rule).
#pragma once

namespace ms::schedule {

// 16 hex digits.
const char* source_fingerprint();

}  // namespace ms::schedule
