// checksum.cpp — fnv1a64 (palpate/core.h).
#include <palpate/core.h>

#include <bit>
#include <cstring>

namespace palpate {

std::uint64_t fnv1a64(const void* bytes, std::size_t size) noexcept {
  static_assert(std::endian::native == std::endian::little, "palpate's binary files are little-endian");
  const auto* data = static_cast<const unsigned char*>(bytes);
  constexpr std::uint64_t kPrime = 0x100000001b3ULL;
  std::uint64_t h = 0xcbf29ce484222325ULL;
  std::size_t i = 0;
  for (; i + 8 <= size; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, data + i, 8);
    h = (h ^ w) * kPrime;
  }
  for (; i < size; ++i) h = (h ^ data[i]) * kPrime;
  return h;
}

}  // namespace palpate
