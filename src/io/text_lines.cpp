// text_lines.cpp — line-numbered token reading and strict number parsing for the text mesh readers.
#include "io/text_lines.h"

#include <cctype>
#include <charconv>
#include <system_error>

namespace palpate::io {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

}  // namespace

void TokenReader::skip_space(bool stop_at_newline) {
  while (pos_ < text_.size()) {
    const char c = text_[pos_];
    if (c == '\n') {
      if (stop_at_newline) return;
      ++line_;
      ++pos_;
    } else if (is_space(c)) {
      ++pos_;
    } else if (comment_ != '\0' && c == comment_) {
      while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    } else {
      return;
    }
  }
}

bool TokenReader::next(std::string_view& token) {
  skip_space(false);
  if (pos_ >= text_.size()) {
    token_line_ = line_;
    return false;
  }
  const size_t start = pos_;
  while (pos_ < text_.size() && text_[pos_] != '\n' && !is_space(text_[pos_]) &&
         !(comment_ != '\0' && text_[pos_] == comment_))
    ++pos_;
  token = text_.substr(start, pos_ - start);
  token_line_ = line_;
  return true;
}

bool TokenReader::peek(std::string_view& token) {
  const size_t pos = pos_;
  const int line = line_, token_line = token_line_;
  const bool found = next(token);
  pos_ = pos;
  line_ = line;
  token_line_ = token_line;
  return found;
}

std::string_view TokenReader::rest_of_line() {
  skip_space(true);
  const size_t start = pos_;
  while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  size_t end = pos_;
  while (end > start && is_space(text_[end - 1])) --end;
  return text_.substr(start, end - start);
}

bool TokenReader::next_line() {
  while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  if (pos_ >= text_.size()) return false;
  ++pos_;
  ++line_;
  return true;
}

bool TokenReader::line_tokens(std::string_view* tokens, size_t capacity, size_t& count,
                              size_t& total) {
  for (;;) {
    count = 0;
    total = 0;
    skip_space(true);
    if (pos_ >= text_.size()) return false;
    token_line_ = line_;
    while (pos_ < text_.size() && text_[pos_] != '\n') {
      std::string_view token;
      const size_t start = pos_;
      while (pos_ < text_.size() && text_[pos_] != '\n' && !is_space(text_[pos_]) &&
             !(comment_ != '\0' && text_[pos_] == comment_))
        ++pos_;
      token = text_.substr(start, pos_ - start);
      if (!token.empty()) {
        if (count < capacity) tokens[count++] = token;
        ++total;
      }
      skip_space(true);
    }
    if (pos_ < text_.size()) {  // consume the newline
      ++pos_;
      ++line_;
    }
    if (total > 0) return true;
  }
}

bool parse_double(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, value);
  return ec == std::errc() && ptr == end;
}

bool parse_int(std::string_view token, long long& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, value);
  return ec == std::errc() && ptr == end;
}

std::string printable(std::string_view token) {
  std::string out;
  for (char c : token.substr(0, 40)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  if (token.size() > 40) out += "...";
  return out;
}

}  // namespace palpate::io
