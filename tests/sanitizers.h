// Whether the test is built with AddressSanitizer: some checks send fewer rays there, or leave out what its shadow
// memory forbids (a limit on the address space).
#pragma once

namespace raylife::testing {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderAddressSanitizer = true; // GCC's -fsanitize=address
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kUnderAddressSanitizer = true; // clang's
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif

} // namespace raylife::testing
