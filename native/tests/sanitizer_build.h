// Whether this test binary runs under AddressSanitizer or ThreadSanitizer
// (setup.sh sanitize / tsan): their shadow memory takes terabytes of address
// space, so tests that limit the address space (ulimit -v, RLIMIT_AS) skip there.
#pragma once

namespace arap_test {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerBuild = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitizerBuild = true;
#else
constexpr bool kSanitizerBuild = false;
#endif
#else
constexpr bool kSanitizerBuild = false;
#endif

}  // namespace arap_test
