// png.cpp — PNG encoding (stb_image_write) and atomic image files.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>

#include <palpate/render.h>

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

namespace palpate {
namespace {

void append_bytes(void* context, void* data, int size) {
  auto* out = static_cast<std::vector<uint8_t>*>(context);
  const auto* bytes = static_cast<const uint8_t*>(data);
  out->insert(out->end(), bytes, bytes + size);
}

}  // namespace

Status write_png(const Image& image, const std::filesystem::path& file) {
  if (image.width < 1 || image.height < 1 || image.rgba.size() != size_t(image.width) * image.height * 4)
    return Error{file.string() + ": image is " + std::to_string(image.width) + " x " +
                 std::to_string(image.height) + " with " + std::to_string(image.rgba.size()) +
                 " bytes; expected width x height x 4 bytes of RGBA"};
  std::vector<uint8_t> png;
  png.reserve(image.rgba.size() / 4);
  if (!stbi_write_png_to_func(append_bytes, &png, image.width, image.height, 4, image.rgba.data(), image.width * 4))
    return Error{file.string() + ": PNG encoding failed"};

  // Beside the target (same file system, so the rename is atomic), unique per process and call.
  static std::atomic<unsigned> counter{0};
  std::filesystem::path tmp = file;
  tmp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      const std::string why = std::strerror(errno);
      return Error{file.string() + ": cannot write (" + why + "); expected a writable directory"};
    }
    out.write(reinterpret_cast<const char*>(png.data()), std::streamsize(png.size()));
    out.close();
    if (!out) {
      std::error_code ignore;
      std::filesystem::remove(tmp, ignore);
      return Error{file.string() + ": write failed (disk full?)"};
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    std::error_code ignore;
    std::filesystem::remove(tmp, ignore);
    return Error{file.string() + ": cannot replace (" + ec.message() + ")"};
  }
  return {};
}

Status render_png(const RenderScene& scene, const std::filesystem::path& file) {
  auto image = render_rgba(scene);
  if (!image) return Error{file.string() + ": " + image.error().message};
  return write_png(*image, file);
}

}  // namespace palpate
