// msh_check.h — internal: the checks a Gmsh .msh file passes before Gmsh reads it (counts against
// the file's size, element types and nodes, binary block headers, byte order: each found by
// fuzzing to make Gmsh crash or allocate gigabytes), and the walk over its bytes they share.
#pragma once

#include <palpate/core.h>

#include "io/mesh_io.h"
#include "io/text_lines.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>

namespace palpate::io {

// The first line opens a mesh section: Gmsh parses any other file as a .geo script (which can run
// commands), so only such a file is handed to it.
Status check_msh_header(const std::filesystem::path& file);
// Every count, element and block of the file, as the version's reader in Gmsh 4.8 walks it.
Status check_msh_counts(const std::filesystem::path& file);

// C stdio over the file's bytes, as Gmsh's readers use it: fgets into their 256-byte buffer,
// fread, and fscanf's %d and %lf. A walk with it stays where Gmsh's reading is. A number is taken
// only when its whole whitespace-delimited token is one: fscanf would stop inside "1.5x" and read
// on from there, so such a token is refused and every accepted file is read the same by both.
class StdioWalk {
 public:
  // `line_max`: the bytes one fgets reads at most (its buffer's size less one).
  explicit StdioWalk(std::string_view t, size_t line_max = 255) : t_(t), line_max_(line_max) {}
  // fgets(str, line_max + 1, fp): up to line_max bytes, through the first '\n'; false (str
  // unchanged) at the end.
  bool gets(std::string& str) { return gets(str, line_max_); }
  bool gets(std::string& str, size_t line_max) {
    size_t n = 0;
    while (n < line_max) {
      if (at_ + n >= t_.size()) {
        eof_ = true;
        break;
      }
      if (t_[at_ + n++] == '\n') break;
    }
    if (n == 0) return false;
    line_at_ = at_;
    str.assign(t_.substr(at_, n));
    at_ += n;
    return true;
  }
  bool read(void* out, size_t n) {  // fread
    if (n > t_.size() - at_) {
      at_ = t_.size();
      eof_ = true;
      return false;
    }
    std::memcpy(out, t_.data() + at_, n);
    at_ += n;
    return true;
  }
  bool scan_int(long long& v) {  // fscanf(fp, "%d")
    std::string_view tok;
    return token(tok) && parse_int(tok, v) && v >= std::numeric_limits<std::int32_t>::min() &&
           v <= std::numeric_limits<std::int32_t>::max();
  }
  bool scan_double(double& v) {  // fscanf(fp, "%lf")
    std::string_view tok;
    return token(tok) && parse_double(tok, v);
  }
  void skip(size_t n) { at_ += std::min(n, t_.size() - at_); }  // what a section's own walk read
  bool eof() const { return eof_; }
  size_t at() const { return at_; }
  // The line of the last fgets, and of the last token (or where a missing one was looked for).
  int gets_line() const { return line_of(line_at_); }
  int token_line() const { return line_of(token_at_); }

 private:
  static bool c_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r'; }
  int line_of(size_t at) const {
    return 1 + static_cast<int>(std::count(t_.begin(), t_.begin() + static_cast<std::ptrdiff_t>(std::min(at, t_.size())), '\n'));
  }
  bool token(std::string_view& tok) {
    while (at_ < t_.size() && c_space(t_[at_])) ++at_;
    token_at_ = at_;
    while (at_ < t_.size() && !c_space(t_[at_])) ++at_;
    if (at_ == t_.size()) eof_ = true;  // fscanf looked past the end for the token's end
    tok = t_.substr(token_at_, at_ - token_at_);
    return !tok.empty();
  }
  std::string_view t_;
  size_t line_max_;
  size_t at_ = 0, line_at_ = 0, token_at_ = 0;
  bool eof_ = false;
};

// Nodes of each Gmsh element type up to 15 (the types Gmsh 4.8 writes for meshes of order ≤ 2).
inline constexpr int kNodesOfType[] = {0, 2, 3, 4, 4, 8, 6, 5, 3, 6, 9, 10, 27, 18, 14, 1};

// Shared by the format-2 and format-4 checks (msh_check.cpp, msh_check_v2.cpp).
Status check_byte_order(StdioWalk& f, int line, const std::string& name);
std::string_view after_first(const std::string& str);
bool starts(std::string_view s, std::string_view prefix);
std::string section_shown(std::string_view name);
Status check_msh2(const std::string& t, double max_count, const std::string& name);

}  // namespace palpate::io
