// palpate/image.h — an RGBA image in memory and its PNG file (the io layer: the renderer and the
// ultrasound imager both write through it, neither through the other).
#pragma once

#include <palpate/core.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace palpate {

// An 8-bit RGBA image, rows top to bottom.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;            // (height x width x 4)
  const uint8_t* pixel(int x, int y) const { return &rgba[(size_t(y) * width + x) * 4]; }
};

// Write a PNG atomically: to a temporary file beside `file`, renamed over it when complete, so
// a reader never sees half an image. Fails naming the file when it cannot be written.
Status write_png(const Image& image, const std::filesystem::path& file);

// The PNG file's bytes, in memory (a report's data: URI). Fails for a malformed image.
Result<std::string> encode_png(const Image& image);

}  // namespace palpate
