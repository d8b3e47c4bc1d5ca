// csv_rows.cpp — CsvRows: line-numbered CSV rows for the scripted and replay devices, with
// locale-independent numbers.
#include "io/csv_rows.h"

#include "io/text_lines.h"

namespace palpate::io {

namespace {

bool blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

}  // namespace

Result<CsvRows> CsvRows::open(const std::filesystem::path& file, const char* what) {
  if (Status s = check_regular_file(file, std::string("a ") + what + " (CSV)"); !s) return s.error();
  std::ifstream in(file);
  if (!in) return Error{file.string() + ": cannot open " + what};
  return CsvRows(file, std::move(in));
}

bool CsvRows::next(std::vector<std::string_view>& fields, bool whitespace_too) {
  fields.clear();
  while (std::getline(in_, text_)) {
    ++line_;
    const std::string_view line = trim(text_);
    if (line.empty() || line.front() == '#') continue;
    if (whitespace_too) {
      size_t i = 0;
      while (i < line.size()) {
        while (i < line.size() && (line[i] == ',' || blank(line[i]))) ++i;
        const size_t start = i;
        while (i < line.size() && line[i] != ',' && !blank(line[i])) ++i;
        if (i > start) fields.push_back(line.substr(start, i - start));
      }
    } else {
      size_t start = 0;
      for (;;) {
        const size_t comma = line.find(',', start);
        fields.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos
                                                                                 : comma - start)));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
      }
    }
    return true;
  }
  return false;
}

bool csv_number(std::string_view field, double& value) { return parse_double(trim(field), value); }

}  // namespace palpate::io
