// png_read.h — tests' PNG reader (stb_image, compiled static into each test file that includes it)
// and a pixel-difference count for checking images by content.
#pragma once

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

namespace palpate::test {

struct Png {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;  // (height x width x 3)
  const unsigned char* at(int x, int y) const { return &rgb[(static_cast<size_t>(y) * width + x) * 3]; }
};

// The image as 8-bit RGB; empty (0 x 0) when the file is missing or not an image.
inline Png load_png(const std::filesystem::path& file) {
  Png png;
  int channels = 0;
  unsigned char* data = stbi_load(file.c_str(), &png.width, &png.height, &channels, 3);
  if (!data) return Png{};
  png.rgb.assign(data, data + static_cast<size_t>(png.width) * png.height * 3);
  stbi_image_free(data);
  return png;
}

// Pixels whose colours differ by more than `threshold` (sum of |ΔR|, |ΔG|, |ΔB|); images of
// different sizes differ everywhere.
inline long changed_pixels(const Png& a, const Png& b, int threshold = 24) {
  if (a.width != b.width || a.height != b.height) return long(std::max(a.rgb.size(), b.rgb.size()) / 3);
  long n = 0;
  for (size_t i = 0; i + 2 < a.rgb.size(); i += 3) {
    const int d = std::abs(int(a.rgb[i]) - int(b.rgb[i])) + std::abs(int(a.rgb[i + 1]) - int(b.rgb[i + 1])) +
                  std::abs(int(a.rgb[i + 2]) - int(b.rgb[i + 2]));
    n += d > threshold ? 1 : 0;
  }
  return n;
}

}  // namespace palpate::test
