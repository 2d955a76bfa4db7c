// Whether this program was built with AddressSanitizer (the sanitizer stage, deploy/sanitize.sh). ASan's redzones,
// shadow memory and quarantine of freed blocks add to every allocation, and its shadow maps terabytes of address
// space: a bound on a process's resident or address-space size measures ASan there, not kiln, so such bounds are
// checked in the normal build only (LeakSanitizer checks those programs' leaks instead).
#pragma once

namespace kiln::test {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kUnderAddressSanitizer = true;
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif

}  // namespace kiln::test
