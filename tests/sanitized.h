// sanitized.h — whether this test binary is built with a sanitizer (AddressSanitizer, UBSan,
// ThreadSanitizer; kAddressSanitized: AddressSanitizer itself), where a tick runs ~50 times slower:
// the scenario tests that run whole shipped scenes or meshes of 10⁴–10⁵ vertices take a lighter
// form there (docs/RELIABILITY.md, Sanitizers); the release suite runs them in full.
#pragma once

#if !defined(__has_feature)
#define __has_feature(x) 0  // gcc: __SANITIZE_ADDRESS__ / __SANITIZE_THREAD__ say it; clang: __has_feature
#endif
#if defined(__SANITIZE_ADDRESS__) || __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitized = true;  // AddressSanitizer itself (its shadow memory, LeakSanitizer)
#else
inline constexpr bool kAddressSanitized = false;
#endif
#if defined(__SANITIZE_THREAD__) || __has_feature(thread_sanitizer) || __has_feature(undefined_behavior_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = kAddressSanitized;
#endif
