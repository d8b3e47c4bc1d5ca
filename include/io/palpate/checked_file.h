// palpate/checked_file.h — a versioned, checksummed binary file (the io layer): bytes in, bytes
// out, with the header that proves they are whole. The spring model's predictor is one (its
// payload is the model's business: palpate/spring.h's encode_predictor / decode_predictor).
//
// Layout (little-endian): 8-byte magic, u32 version, u32 reserved (0), u64 payload size, u64
// FNV-1a 64 checksum of the payload (fnv1a64), then the payload.
#pragma once

#include <palpate/core.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace palpate {

struct CheckedFileFormat {
  std::array<char, 8> magic{};
  std::uint32_t version = 1;
  const char* name = "";      // in messages: "predictor file" ("cannot open the predictor file")
  const char* expected = "";  // what the path must be: "a palpate predictor file (material.predictor)"
};

inline constexpr std::size_t kCheckedFileHeaderSize = 32;

// Write header and payload to `file` atomically, flushed to disk before the rename (fsync): a
// killed writer or a lost power leaves the old file or none, never a half-written one.
Status write_checked_file(const std::filesystem::path& file, const CheckedFileFormat& format,
                          std::string_view payload);

// The payload of `file`, after checking that it is a regular file, the magic, the version, the
// size and the checksum. Errors start with the file's path: "x.predictor: corrupted: checksum
// mismatch", "... not a palpate predictor file (bad magic)", "... truncated: 10 bytes, shorter than
// the header", "... predictor file version 2, this palpate reads version 1".
Result<std::string> read_checked_file(const std::filesystem::path& file, const CheckedFileFormat& format);

}  // namespace palpate
