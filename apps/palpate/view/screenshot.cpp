// screenshot.cpp — framebuffer read-back, written as a PNG by the library's atomic write_png.
#include "screenshot.h"

#include <epoxy/gl.h>
#include <palpate/render.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

namespace palpate::view {

std::vector<std::uint8_t> read_framebuffer(int width, int height) {
  const size_t row = static_cast<size_t>(width) * 4;
  std::vector<std::uint8_t> bottom_up(row * static_cast<size_t>(height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, bottom_up.data());
  std::vector<std::uint8_t> top_down(bottom_up.size());
  for (int y = 0; y < height; ++y)
    std::memcpy(&top_down[static_cast<size_t>(y) * row], &bottom_up[static_cast<size_t>(height - 1 - y) * row], row);
  return top_down;
}

Status write_png_atomic(const std::filesystem::path& file, int width, int height,
                        const std::vector<std::uint8_t>& rgba) {
  return write_png(Image{width, height, rgba}, file);
}

}  // namespace palpate::view
