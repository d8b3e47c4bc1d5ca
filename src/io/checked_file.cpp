// checked_file.cpp — the versioned, checksummed binary file (palpate/checked_file.h).
#include <palpate/checked_file.h>

#include <cstring>
#include <fstream>
#include <string>

namespace palpate {

Status write_checked_file(const std::filesystem::path& file, const CheckedFileFormat& format,
                          std::string_view payload) {
  std::string buf(kCheckedFileHeaderSize, '\0');
  buf.reserve(kCheckedFileHeaderSize + payload.size());
  const std::uint64_t size = payload.size();
  const std::uint64_t sum = fnv1a64(payload.data(), payload.size());
  std::memcpy(buf.data(), format.magic.data(), 8);
  std::memcpy(buf.data() + 8, &format.version, 4);
  std::memcpy(buf.data() + 16, &size, 8);
  std::memcpy(buf.data() + 24, &sum, 8);
  buf.append(payload);
  return write_file_atomic(file, buf, true);
}

Result<std::string> read_checked_file(const std::filesystem::path& file, const CheckedFileFormat& format) {
  const std::string where = file.string() + ": ";
  const std::string name = format.name;
  if (Status s = check_regular_file(file, format.expected); !s) return s.error();
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) return Error{where + "cannot open the " + name};
  const std::streamoff size = in.tellg();
  if (size < 0) return Error{where + "cannot read the " + name};
  std::string data(static_cast<size_t>(size), '\0');
  in.seekg(0);
  in.read(data.data(), size);
  if (!in) return Error{where + "cannot read the " + name};
  if (data.size() < 8 || std::memcmp(data.data(), format.magic.data(), 8) != 0)
    return Error{where + "not a palpate " + name + " (bad magic)"};
  if (data.size() < kCheckedFileHeaderSize)
    return Error{where + "truncated: " + std::to_string(data.size()) + " bytes, shorter than the header"};
  std::uint32_t version;
  std::uint64_t payload, sum;
  std::memcpy(&version, data.data() + 8, 4);
  std::memcpy(&payload, data.data() + 16, 8);
  std::memcpy(&sum, data.data() + 24, 8);
  if (version != format.version)
    return Error{where + name + " version " + std::to_string(version) + ", this palpate reads version " +
                 std::to_string(format.version)};
  if (data.size() - kCheckedFileHeaderSize < payload)
    return Error{where + "truncated: " + std::to_string(data.size()) + " bytes, expected " +
                 std::to_string(payload + kCheckedFileHeaderSize)};
  if (data.size() - kCheckedFileHeaderSize > payload)
    return Error{where + "corrupted: " + std::to_string(data.size() - kCheckedFileHeaderSize - payload) +
                 " bytes after the payload"};
  if (fnv1a64(data.data() + kCheckedFileHeaderSize, payload) != sum) return Error{where + "corrupted: checksum mismatch"};
  data.erase(0, kCheckedFileHeaderSize);
  return data;
}

}  // namespace palpate
