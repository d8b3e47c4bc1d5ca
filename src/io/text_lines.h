// text_lines.h — internal: a line-numbered reader of whitespace-separated tokens for the
// hand-written mesh readers (TetGen, legacy VTK), so every error can name its line.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace palpate::io {

class TokenReader {
 public:
  // `text` must outlive the reader. `comment` starts a comment running to the end of the
  // line ('\0' = the format has no comments).
  TokenReader(std::string_view text, char comment) : text_(text), comment_(comment) {}

  // The next token, or false at end of input; `line()` is then the line of that token (1-based).
  bool next(std::string_view& token);
  // Look at the next token without consuming it.
  bool peek(std::string_view& token);
  // The rest of the current line (after the last token read), trimmed, consumed up to the newline.
  std::string_view rest_of_line();
  // Advance to the start of the next line; false at end of input.
  bool next_line();
  // The tokens of the next non-empty line (comment-only lines skipped), or false at end.
  bool line_tokens(std::string_view* tokens, size_t capacity, size_t& count, size_t& total);

  int line() const { return token_line_; }
  size_t position() const { return pos_; }  // the byte after the last token read
  int current_line() const { return line_; }

 private:
  void skip_space(bool stop_at_newline);

  std::string_view text_;
  char comment_;
  size_t pos_ = 0;
  int line_ = 1;        // line of pos_
  int token_line_ = 1;  // line of the last token returned
};

// Number parsing that accepts what C's strtod/strtol accept in mesh files ("+1", "1e-3",
// "nan", "inf"); false when the whole token is not a number or the integer overflows.
bool parse_double(std::string_view token, double& value);
bool parse_int(std::string_view token, long long& value);

// The token for an error message: at most 40 characters, non-printable bytes as '?'.
std::string printable(std::string_view token);

}  // namespace palpate::io
