// fuzz_common.h — what every libFuzzer target shares: the input saved as a file (palpate's readers
// take paths), and the oracle. A reader may refuse an input, with an error that names the file;
// anything else — a crash, a sanitizer report, an exception escaping a Result-returning loader, an
// empty or anonymous message, a hang (-timeout), a leak — is a finding.
#pragma once

#include <palpate/core.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace palpate::fuzz {

// One directory per process (reused by every input), removed at exit.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::filesystem::path d = std::filesystem::path(tmp && *tmp ? tmp : "/tmp") /
                              ("palpate-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    static struct Cleanup {
      std::filesystem::path d;
      ~Cleanup() {
        std::error_code ec;
        std::filesystem::remove_all(d, ec);
      }
    } cleanup{d};
    return d;
  }();
  return dir;
}

// `bytes` written to scratch_dir()/<name>, replacing what an earlier input left there.
inline std::filesystem::path write_file(const std::string& name, std::string_view bytes) {
  const std::filesystem::path p = scratch_dir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", p.c_str());
    std::abort();
  }
  return p;
}

// The fuzzer's bytes as text.
inline std::string_view bytes(const unsigned char* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// The fuzzer's input saved as scratch_dir()/<name> (palpate's readers take paths): the prologue
// of every target that hands one file to a reader.
inline std::filesystem::path save_input(const std::string& name, const unsigned char* data, size_t size) {
  return write_file(name, bytes(data, size));
}

// The oracle for a refusal: a message, naming `where` (the file, or the scene's name).
inline void check_error(const Error& e, std::string_view where) {
  if (e.message.empty() || e.message.find(where) == std::string::npos) {
    std::fprintf(stderr, "fuzz: a refusal without a clear message (expected it to name '%.*s'): '%s'\n",
                 static_cast<int>(where.size()), where.data(), e.message.c_str());
    std::abort();
  }
}

template <class R>
void check(const R& result, std::string_view where) {
  if (!result.ok()) check_error(result.error(), where);
}

// Runs `body`; an exception out of a loader that reports errors by Result is a finding.
template <class F>
void no_throw(F&& body) {
  try {
    body();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: exception escaped the loader: %s\n", e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "fuzz: unknown exception escaped the loader\n");
    std::abort();
  }
}

}  // namespace palpate::fuzz
