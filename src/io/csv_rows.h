// csv_rows.h — internal: the one line-numbered CSV reader of the trajectory (scripted device) and
// recording (replay device) files. Numbers are read with std::from_chars, never through the
// process's locale: an embedding program that set a comma-decimal locale still reads them.
#pragma once

#include <palpate/core.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace palpate::io {

class CsvRows {
 public:
  // Open `file`; `what` names it in the error ("trajectory file", "recording").
  static Result<CsvRows> open(const std::filesystem::path& file, const char* what);

  // The next line that is neither blank nor a '#' comment, split into fields (trimmed of spaces,
  // tabs and '\r'): at commas, or with `whitespace_too` at commas and runs of blanks (empty fields
  // then dropped). False at the end of the file.
  bool next(std::vector<std::string_view>& fields, bool whitespace_too = false);
  // The line the last next() returned (1-based), and "file:line: " for an error about it.
  int line() const { return line_; }
  std::string where() const { return file_.string() + ":" + std::to_string(line_) + ": "; }
  const std::filesystem::path& file() const { return file_; }

 private:
  CsvRows(std::filesystem::path file, std::ifstream in) : file_(std::move(file)), in_(std::move(in)) {}
  std::filesystem::path file_;
  std::ifstream in_;
  std::string text_;  // the current line; fields view into it
  int line_ = 0;
};

// A number field: the whole field read by std::from_chars in the C locale's syntax ("1.5",
// "-2e-3", "+4", "nan", "inf"); false when it is not a number or out of double's range.
bool csv_number(std::string_view field, double& value);

}  // namespace palpate::io
