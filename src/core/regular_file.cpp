// regular_file.cpp — check_regular_file: refuse a path that is not a regular file before it is opened.
#include <palpate/core.h>

#include <string>
#include <system_error>

namespace palpate {

Status check_regular_file(const std::filesystem::path& file, std::string_view expected) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(file, ec);
  const std::string want = "; expected " + std::string(expected);
  if (ec || !fs::exists(st)) {
    if (ec && ec != std::errc::no_such_file_or_directory)
      return Error{file.string() + ": cannot look at it (" + ec.message() + ")" + want};
    return Error{file.string() + ": no such file" + want};
  }
  const char* kind = nullptr;
  switch (st.type()) {
    case fs::file_type::regular: return {};
    case fs::file_type::directory: kind = "a directory"; break;
    case fs::file_type::fifo: kind = "a FIFO (named pipe)"; break;
    case fs::file_type::character: kind = "a character device"; break;
    case fs::file_type::block: kind = "a block device"; break;
    case fs::file_type::socket: kind = "a socket"; break;
    default: kind = "not a regular file"; break;
  }
  return Error{file.string() + ": is " + std::string(kind) + ", not a regular file" + want};
}

}  // namespace palpate
