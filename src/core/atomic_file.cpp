// atomic_file.cpp — write_file_atomic: temporary file beside the target, fsync, rename; the
// removal of the temporaries a killed writer left; the cache folder.
#include <palpate/core.h>

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
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

size_t remove_stale_temporaries(const std::filesystem::path& file) noexcept {
  namespace fs = std::filesystem;
  const std::string prefix = file.filename().string() + ".tmp-";
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) return 0;
  size_t removed = 0;
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) break;
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    // "<pid>-<n>": kept while that process runs (it may be writing now), removed once it has gone.
    char* end = nullptr;
    const long pid = std::strtol(name.c_str() + prefix.size(), &end, 10);
    if (pid <= 0 || !end || *end != '-') continue;
    if (pid == ::getpid() || ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code gone;
    if (fs::remove(it->path(), gone)) ++removed;
  }
  return removed;
}

std::filesystem::path default_cache_dir() {
  namespace fs = std::filesystem;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg && fs::path(xdg).is_absolute())
    return fs::path(xdg) / "palpate";
  if (const char* home = std::getenv("HOME"); home && *home && fs::path(home).is_absolute())
    return fs::path(home) / ".cache" / "palpate";
  return {};  // no home: no cache (a shared temporary folder another user could plant files in is no place for one)
}

}  // namespace palpate
