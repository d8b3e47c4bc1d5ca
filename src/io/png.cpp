// png.cpp — PNG encoding (stb_image_write), written with write_file_atomic.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>

#include <palpate/image.h>

#include <string>
#include <vector>

namespace palpate {
namespace {

void append_bytes(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
}

}  // namespace

Result<std::string> encode_png(const Image& image) {
  if (image.width < 1 || image.height < 1 || image.rgba.size() != size_t(image.width) * image.height * 4)
    return Error{"image is " + std::to_string(image.width) + " x " + std::to_string(image.height) + " with " +
                 std::to_string(image.rgba.size()) + " bytes; expected width x height x 4 bytes of RGBA"};
  std::string png;
  png.reserve(image.rgba.size() / 4);
  if (!stbi_write_png_to_func(append_bytes, &png, image.width, image.height, 4, image.rgba.data(), image.width * 4))
    return Error{"PNG encoding failed"};
  return png;
}

Status write_png(const Image& image, const std::filesystem::path& file) {
  auto png = encode_png(image);
  if (!png) return Error{file.string() + ": " + png.error().message};
  return write_file_atomic(file, *png, /*create_directories=*/false);
}

}  // namespace palpate
