// atomic_file.cpp — write_file_atomic: temporary file beside the target, fsync, rename.
#include <palpate/core.h>

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

namespace palpate {

Status write_file_atomic(const std::filesystem::path& file, std::string_view bytes,
                         bool create_directories) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (create_directories && file.has_parent_path()) fs::create_directories(file.parent_path(), ec);
  if (ec) return Error{file.parent_path().string() + ": cannot create directory: " + ec.message()};
  // Beside the target (same file system, so the rename is atomic), unique per process and call.
  static std::atomic<unsigned> counter{0};
  fs::path tmp = file;
  tmp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) {
    const std::string why = std::strerror(errno);
    return Error{file.string() + ": cannot write (" + why + "); expected a writable directory"};
  }
  const size_t written = std::fwrite(bytes.data(), 1, bytes.size(), f);
  const bool flushed = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const bool closed = std::fclose(f) == 0;
  if (written != bytes.size() || !flushed || !closed) {
    fs::remove(tmp, ec);
    return Error{file.string() + ": write failed (disk full?)"};
  }
  fs::rename(tmp, file, ec);
  if (ec) {
    std::error_code ignore;
    fs::remove(tmp, ignore);
    return Error{file.string() + ": cannot move the finished file into place: " + ec.message()};
  }
  return {};
}

}  // namespace palpate
