// predictor_file.h — internals of the predictor file format: the checksum and the layout constants.
#pragma once

#include <cstddef>
#include <cstdint>

namespace palpate::predictor_file {

// "PALPPRED": the first 8 bytes of every predictor file.
inline constexpr char kMagic[8] = {'P', 'A', 'L', 'P', 'P', 'R', 'E', 'D'};
inline constexpr std::uint32_t kVersion = 1;
// magic (8) + version (4) + reserved (4) + payload size (8) + checksum (8).
inline constexpr std::size_t kHeaderSize = 32;

// FNV-1a 64, word-wise: each little-endian 8-byte word (then each trailing byte) is xor-ed into
// the hash, which is then multiplied by the FNV prime. 8x faster than byte-wise on large payloads.
std::uint64_t checksum(const unsigned char* data, std::size_t size) noexcept;

}  // namespace palpate::predictor_file
