// palpate/core.h — basic types shared by every part of palpate: vectors, errors, results.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace palpate {

using Vec3 = Eigen::Vector3d;  // metres, newtons, metres per second: SI throughout (DESIGN.md §5)
using Vec3f = Eigen::Vector3f;
using Quat = Eigen::Quaterniond;

// A load-time error: what went wrong, where (file, line, key or element), and what was expected.
// Errors during a step are never reported this way; they are counted and recovered (STYLE.md 7).
struct Error {
  std::string message;
};

// The value of a fallible load-time operation, or the error that stopped it.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}            // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}        // NOLINT(google-explicit-constructor)
  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() & { return std::get<0>(v_); }
  const T& value() const& { return std::get<0>(v_); }
  T&& value() && { return std::get<0>(std::move(v_)); }
  T* operator->() { return &std::get<0>(v_); }
  const T* operator->() const { return &std::get<0>(v_); }
  T& operator*() & { return std::get<0>(v_); }
  const T& operator*() const& { return std::get<0>(v_); }
  const Error& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

// Result of an operation that produces nothing but may fail.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { return error_; }

 private:
  Error error_;
  bool ok_ = true;
};

// Write `bytes` to `file` atomically: to a temporary file beside it (unique per process and call),
// flushed to disk, then renamed over `file`, so a reader never sees half a file and an
// interrupted write leaves the old one. `create_directories`: make missing parent directories.
// Errors name the file and the reason.
Status write_file_atomic(const std::filesystem::path& file, std::string_view bytes,
                         bool create_directories = true);

// Remove the temporary files write_file_atomic left beside `file` ("<file>.tmp-<pid>-<n>") whose
// writer is no longer running (a run killed while saving); a running writer's are kept. Returns how
// many were removed. Never throws; a folder it cannot read removes nothing.
size_t remove_stale_temporaries(const std::filesystem::path& file) noexcept;

// The folder palpate keeps caches in (not created here): $XDG_CACHE_HOME/palpate when that is an
// absolute path, else $HOME/.cache/palpate; empty (keep no cache) when neither is set.
std::filesystem::path default_cache_dir();

// Whether `file` is a regular file (symbolic links followed), checked with stat before anything
// opens it: a directory, a FIFO (opening it would block), a device such as /dev/zero (reading it
// would never end) or a socket is refused naming the path, what it is, and `expected` ("a YAML
// scene file"); a missing path says so. Every path a run reads goes through it.
Status check_regular_file(const std::filesystem::path& file, std::string_view expected);

// FNV-1a 64, word-wise: each little-endian 8-byte word (then each trailing byte) is xor-ed into the
// hash, which is then multiplied by the FNV prime (8x faster than byte-wise on large payloads).
// The checksum of palpate's binary files and the predictor's mesh hash.
std::uint64_t fnv1a64(const void* data, std::size_t size) noexcept;

// Text made safe inside XML and HTML markup (a VTK file's names, report.html): & < > " ' as their
// entities, everything else (UTF-8 too) as it is.
std::string markup_escape(std::string_view text);

// The library's version, "MAJOR.MINOR.PATCH".
const char* version();

// The optional components this palpate was built with (CMake options PALPATE_WITH_OSMESA, _GMSH,
// _CGAL; README), each "yes" or "no": "OSMesa yes, Gmsh yes, CGAL yes". Without one, the functions
// that need it fail with an error naming the option. Code compiled against palpate sees the same
// as PALPATE_HAS_OSMESA, PALPATE_HAS_GMSH and PALPATE_HAS_CGAL (1 or 0).
std::string components();

}  // namespace palpate
