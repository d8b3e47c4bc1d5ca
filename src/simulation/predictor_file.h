// predictor_file.h — internal: the predictor file's format constants (palpate/checked_file.h's
// header with this magic and version around decode_predictor's payload), for the tests and fuzz
// targets that damage files on purpose.
#pragma once

#include <palpate/checked_file.h>

#include <cstddef>
#include <cstdint>

namespace palpate::predictor_file {

// "PALPPRED": the first 8 bytes of every predictor file.
inline constexpr char kMagic[8] = {'P', 'A', 'L', 'P', 'P', 'R', 'E', 'D'};
inline constexpr std::uint32_t kVersion = 1;
// magic (8) + version (4) + reserved (4) + payload size (8) + checksum (8).
inline constexpr std::size_t kHeaderSize = kCheckedFileHeaderSize;

inline std::uint64_t checksum(const unsigned char* data, std::size_t size) noexcept { return fnv1a64(data, size); }

}  // namespace palpate::predictor_file
