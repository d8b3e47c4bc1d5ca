// screenshot.h — PNG screenshots of the viewer's window, written atomically.
#pragma once

#include <palpate/core.h>

#include <cstdint>
#include <filesystem>
#include <vector>

namespace palpate::view {

// Read the current framebuffer's colour (`width` x `height`, as glReadPixels sees it: rows bottom
// to top) into RGBA rows top to bottom. Needs the GL context current.
std::vector<std::uint8_t> read_framebuffer(int width, int height);

// Write RGBA rows (top to bottom) as a PNG: to a temporary file beside it, renamed over `file` when
// complete, so a reader never sees half an image (palpate::write_png). Errors name the file and the reason.
Status write_png_atomic(const std::filesystem::path& file, int width, int height,
                        const std::vector<std::uint8_t>& rgba);

}  // namespace palpate::view
