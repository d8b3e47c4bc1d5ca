// screenshot.cpp — framebuffer read-back and the atomic PNG writer (stb_image_write from libstb).
#include "screenshot.h"

#include <epoxy/gl.h>
#include <stb/stb_image_write.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

namespace palpate::view {

namespace {

void append_bytes(void* context, void* data, int size) {
  auto* out = static_cast<std::string*>(context);
  out->append(static_cast<const char*>(data), static_cast<size_t>(size));
}

}  // namespace

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
  if (width <= 0 || height <= 0 || rgba.size() != static_cast<size_t>(width) * static_cast<size_t>(height) * 4)
    return Error{file.string() + ": cannot write a " + std::to_string(width) + "x" + std::to_string(height) +
                 " screenshot from " + std::to_string(rgba.size()) + " bytes of RGBA"};
  std::string png;
  if (!stbi_write_png_to_func(append_bytes, &png, width, height, 4, rgba.data(), width * 4) || png.empty())
    return Error{file.string() + ": PNG encoding failed"};
  std::filesystem::path part = file;
  part += ".part";
  std::FILE* f = std::fopen(part.c_str(), "wb");
  if (!f) return Error{part.string() + ": cannot open for writing: " + std::strerror(errno)};
  const bool written = std::fwrite(png.data(), 1, png.size(), f) == png.size();
  const bool closed = std::fclose(f) == 0;
  if (!written || !closed) {
    std::error_code ignored;
    std::filesystem::remove(part, ignored);
    return Error{part.string() + ": writing the screenshot failed (disk full?)"};
  }
  std::error_code ec;
  std::filesystem::rename(part, file, ec);
  if (ec) {
    std::filesystem::remove(part, ec);
    return Error{file.string() + ": cannot rename the finished screenshot into place: " + ec.message()};
  }
  return {};
}

}  // namespace palpate::view
