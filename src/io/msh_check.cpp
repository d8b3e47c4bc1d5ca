// msh_check.cpp — the checks of a .msh file's header and of formats 4.x (io/msh_check.h); formats
// 1 and 2 in msh_check_v2.cpp.
#include "io/msh_check.h"
#include "io/text_lines.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace palpate::io {

// Gmsh parses any file not starting with '$' as a .geo script (which can run commands): only a
// file whose first line opens a mesh section is handed to it.
Status check_msh_header(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string first;
  char c = 0;
  while (in.get(c) && (c == ' ' || c == '\t' || c == '\r' || c == '\n')) {
  }
  if (in) first += c;
  while (first.size() < 64 && in.get(c) && c != '\n' && c != '\r') first += c;
  while (!first.empty() && (first.back() == ' ' || first.back() == '\t')) first.pop_back();
  for (const char* ok : {"$MeshFormat", "$NOD", "$NOE", "$Comments"})
    if (first == ok) return {};
  std::string shown;
  for (char ch : first.substr(0, 40)) shown += (ch >= 32 && ch < 127) ? ch : '?';
  return Error{fmt::format("{}:1: expected a Gmsh mesh header ($MeshFormat, or $NOD for format 1), found '{}'",
                           file.string(), shown)};
}


namespace {

// Gmsh 4.8's ASCII format-4 reader trusts each section's totals and writes past its arrays when
// the blocks hold more than the total promised (found by fuzzing: a one-digit change crashes
// it). Check that the blocks of $Nodes and $Elements add up to their totals and that tags lie
// in the promised range. `body` starts on the line after the section's name, which is `line`;
// `used`: the bytes Gmsh's reader will have read (every token is checked to be a number, so
// fscanf's reading stops where this one does).
Status check_msh4_block_sums(std::string_view body, bool nodes, int line, const std::string& name,
                             std::uint64_t node_min, std::uint64_t node_max, size_t& used) {
  TokenReader in(body, '\0');
  const auto error = [&](const std::string& what) {
    return Error{fmt::format("{}:{}: {}: {}", name, line + in.line(), nodes ? "$Nodes" : "$Elements", what)};
  };
  const auto number = [&](long long& v, const char* what) -> Status {
    std::string_view t;
    if (!in.next(t)) return error(fmt::format("unexpected end of file, expected {}", what));
    if (!parse_int(t, v)) return error(fmt::format("expected {} (an integer), found '{}'", what, printable(t)));
    return {};
  };
  long long blocks = 0, total = 0, min_tag = 0, max_tag = 0;
  for (auto [v, what] : {std::pair{&blocks, "the number of blocks"}, {&total, "the total count"},
                         {&min_tag, "the smallest tag"}, {&max_tag, "the largest tag"}})
    if (Status s = number(*v, what); !s) return s;
  // A block may be empty (Gmsh writes one per entity, with Mesh.SaveAll points and curves that
  // hold no node of their own), but each takes at least 8 bytes of text.
  if (blocks < 0 || total < 0 || min_tag < 0 || max_tag < min_tag || blocks > static_cast<long long>(body.size() / 8))
    return error(fmt::format("inconsistent header '{} {} {} {}'", blocks, total, min_tag, max_tag));
  long long sum = 0;
  for (long long b = 0; b < blocks; ++b) {
    long long dim = 0, entity = 0, kind = 0, count = 0;
    for (auto [v, what] : {std::pair{&dim, "an entity dimension"}, {&entity, "an entity tag"},
                           {&kind, nodes ? "the parametric flag" : "an element type"}, {&count, "a block size"}})
      if (Status s = number(*v, what); !s) return s;
    sum += count;
    if (dim < 0 || dim > 3 || count < 0 || sum > total)
      return error(fmt::format("block {} ('{} {} {} {}') does not fit the header's total of {}", b, dim, entity, kind,
                               count, total));
    if (nodes) {
      if (kind != 0 && kind != 1) return error(fmt::format("block {}: expected parametric flag 0 or 1, found {}", b, kind));
      // Tags first, then coordinates: 3 each, plus `dim` parametric ones when flagged.
      for (long long i = 0; i < count; ++i) {
        long long tag = 0;
        if (Status s = number(tag, "a node tag"); !s) return s;
        if (tag < min_tag || tag > max_tag)
          return error(fmt::format("node tag {} outside the header's range [{}, {}]", tag, min_tag, max_tag));
      }
      const long long values = count * (3 + (kind ? dim : 0));
      for (long long i = 0; i < values; ++i) {
        std::string_view t;
        double x = 0;
        if (!in.next(t) || !parse_double(t, x)) return error("expected a node coordinate");
      }
    } else {
      // Each element: its tag, then as many nodes as its type has.
      if (kind < 1 || kind > 15) return error(fmt::format("block {}: element type {} is not read", b, kind));
      for (long long i = 0; i < count; ++i) {
        long long tag = 0;
        if (Status s = number(tag, "an element tag"); !s) return s;
        if (tag < min_tag || tag > max_tag)
          return error(fmt::format("element tag {} outside the header's range [{}, {}]", tag, min_tag, max_tag));
        for (int k = 0; k < kNodesOfType[kind]; ++k) {
          long long node = 0;
          if (Status s = number(node, "a node of an element"); !s) return s;
          if (node < 0 || static_cast<std::uint64_t>(node) < node_min || static_cast<std::uint64_t>(node) > node_max)
            return error(fmt::format("element {} has node {} outside the $Nodes range [{}, {}]", tag, node, node_min,
                                     node_max));
        }
      }
    }
  }
  if (sum != total) return error(fmt::format("the blocks hold {}, the header promises {}", sum, total));
  used = in.position();
  return {};
}

// Little-endian values off a binary section, as Gmsh writes them on every machine it ships for.
// A read past the end gives 0, sets `short_read` and still advances, so a walk checks once after
// several reads.
struct ByteCursor {
  std::string_view bytes;
  size_t at = 0;
  bool short_read = false;
  template <class T>
  T get() {
    T v{};
    if (!fits(sizeof(T))) short_read = true;
    else std::memcpy(&v, bytes.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  size_t left() const { return bytes.size() - std::min(at, bytes.size()); }
  bool fits(size_t n) const { return at <= bytes.size() && n <= left(); }
};

// The same check for binary format 4 (little-endian, 8-byte size_t, 4-byte int), where each
// element's node count comes from its type: types Gmsh 4.8 writes for meshes of order ≤ 2.
Status check_msh4_binary_block_sums(std::string_view body, bool nodes, int line, const std::string& name,
                                    std::uint64_t node_min, std::uint64_t node_max, size_t& used) {
  ByteCursor in{body};
  size_t& at = in.at;
  const bool& short_read = in.short_read;
  const auto u64 = [&] { return in.get<std::uint64_t>(); };
  const auto i32 = [&] { return in.get<std::int32_t>(); };
  const auto error = [&](const std::string& what) {
    return Error{fmt::format("{}:{}: {} (binary, byte {} of the section): {}", name, line, nodes ? "$Nodes" : "$Elements",
                             at, what)};
  };
  const std::uint64_t blocks = u64(), total = u64(), min_tag = u64(), max_tag = u64();
  if (short_read) return error("unexpected end of file in the section header");
  // Empty blocks are allowed (see above); each block's header takes 20 bytes.
  if (max_tag < min_tag || blocks > body.size() / 20) return error("inconsistent section header");
  std::uint64_t sum = 0;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    const std::int32_t dim = i32(), entity = i32(), kind = i32();
    const std::uint64_t count = u64();
    if (short_read) return error(fmt::format("unexpected end of file in block {}", b));
    sum += count;
    if (dim < 0 || dim > 3 || count > total || sum > total)
      return error(fmt::format("block {} (entity {} of dimension {}, {} items) does not fit the header's total of {}", b,
                               entity, dim, count, total));
    if (nodes) {
      if (kind != 0 && kind != 1) return error(fmt::format("block {}: expected parametric flag 0 or 1, found {}", b, kind));
      for (std::uint64_t i = 0; i < count; ++i) {
        const std::uint64_t tag = u64();
        if (short_read) return error("unexpected end of file in the node tags");
        if (tag < min_tag || tag > max_tag)
          return error(fmt::format("node tag {} outside the header's range [{}, {}]", tag, min_tag, max_tag));
      }
      at += count * 8 * static_cast<std::uint64_t>(3 + (kind ? dim : 0));
    } else {
      if (kind < 1 || kind > 15) return error(fmt::format("block {}: element type {} is not read", b, kind));
      for (std::uint64_t i = 0; i < count; ++i) {
        const std::uint64_t tag = u64();
        if (short_read) return error("unexpected end of file in the elements");
        if (tag < min_tag || tag > max_tag)
          return error(fmt::format("element tag {} outside the header's range [{}, {}]", tag, min_tag, max_tag));
        // Gmsh's binary reader looks nodes up without a bounds check.
        for (int k = 0; k < kNodesOfType[kind]; ++k) {
          const std::uint64_t node = u64();
          if (short_read) return error("unexpected end of file in the elements");
          if (node < node_min || node > node_max)
            return error(fmt::format("element {} has node {} outside the $Nodes range [{}, {}]", tag, node, node_min,
                                     node_max));
        }
      }
    }
    if (at > body.size()) return error(fmt::format("unexpected end of file in block {}", b));
  }
  if (sum != total) return error(fmt::format("the blocks hold {}, the header promises {}", sum, total));
  used = at;
  return {};
}

}  // namespace

// The int 1 after a binary file's format line (`line`): Gmsh takes anything else for a file of the
// other byte order and swaps every count it reads (found by fuzzing: a damaged one made it ask for
// 2^58 bytes). palpate's checks read little-endian, as Gmsh writes on every machine it ships for.
Status check_byte_order(StdioWalk& f, int line, const std::string& name) {
  std::int32_t one = 0;
  if (!f.read(&one, 4)) return Error{fmt::format("{}:{}: unexpected end of file in the byte-order check", name, line)};
  if (one != 1)
    return Error{fmt::format("{}:{}: binary mesh whose byte-order check reads {} (expected the int 1: a big-endian or "
                             "damaged file; palpate reads little-endian binary meshes)",
                             name, line, one)};
  return {};
}

// What Gmsh sees of fgets' buffer: `&str[1]` as a C string (to its first NUL byte).
std::string_view after_first(const std::string& str) {
  if (str.size() < 2) return {};
  const std::string_view rest = std::string_view(str).substr(1);
  return rest.substr(0, rest.find('\0'));
}
bool starts(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

// A section's name for messages: '$' and the name up to its line's end.
std::string section_shown(std::string_view name) {
  while (!name.empty() && (name.back() == '\n' || name.back() == '\r' || name.back() == ' ')) name.remove_suffix(1);
  std::string shown = "$";
  shown += printable(name);
  return shown;
}

namespace {

// The format version Gmsh 4.8 reads a file as (GModel::readMSH): 1 for a file whose first line
// opens $NOD or $NOE, otherwise the first number after the first section named $MeshFormat;
// false when Gmsh would find no version.
bool gmsh_version(std::string_view t, double& version) {
  StdioWalk f(t);
  std::string str;
  version = 1.0;
  if (!f.gets(str)) return false;
  if (starts(after_first(str), "NOD") || starts(after_first(str), "NOE")) return true;
  StdioWalk again(t);
  str.clear();
  while (true) {
    while (str.empty() || str[0] != '$')
      if (!again.gets(str) || again.eof()) break;
    if (again.eof()) return false;
    if (starts(after_first(str), "MeshFormat")) {
      int format = 0, data_size = 0;  // read as Gmsh does, which wants all three; each walk reads them again
      return again.gets(str) && std::sscanf(str.c_str(), "%lf %d %d", &version, &format, &data_size) == 3;
    }
    do {
      if (!again.gets(str) || again.eof()) break;
    } while (str[0] != '$');
  }
}

// Gmsh 4.8's format-4 entity readers size arrays by counts inside each entity before reading what
// the counts promise: in binary, every entity's physical tags and bounding entities
// (`std::vector<int>(num)`), and in $PartitionedEntities, text or binary, the ghost entities and
// each entity's partitions (found by fuzzing: a surface of a 832-byte binary file promising 3.5e10
// physical tags made Gmsh ask for 141 GB). Walk the section and check each such count against the
// bytes left. `body` starts on the line after the section's name, which is `line`. Binary: format
// 4.1's layout (int tags, 8-byte counts, 3 doubles for a point and 6 for a box); a binary 4.0 file
// is left to Gmsh.
Status check_msh4_entities(std::string_view body, bool binary, bool partitioned, double version, int line,
                           const std::string& name, size_t& used) {
  const char* section = partitioned ? "$PartitionedEntities" : "$Entities";
  used = 0;
  if (binary && version < 4.1) return {};
  TokenReader in(body, '\0');
  ByteCursor bin{body};  // binary: the byte within the section
  const auto where = [&] {
    return binary ? fmt::format("{}:{}: {} (binary, byte {} of the section)", name, line, section, bin.at)
                  : fmt::format("{}:{}: {}", name, line + in.line(), section);
  };
  const auto left = [&] { return binary ? bin.left() : body.size(); };
  // One integer (binary: an 8-byte count, or a 4-byte int when `is_int`).
  const auto integer = [&](long long& v, const char* what, bool is_int) -> Status {
    if (binary) {
      if (!bin.fits(is_int ? 4 : 8))
        return Error{fmt::format("{}: unexpected end of file, expected {}", where(), what)};
      if (is_int) {
        v = bin.get<std::int32_t>();
      } else {
        const std::uint64_t x = bin.get<std::uint64_t>();
        v = x > static_cast<std::uint64_t>(std::numeric_limits<long long>::max()) ? -1 : static_cast<long long>(x);
      }
      return {};
    }
    std::string_view t;
    if (!in.next(t)) return Error{fmt::format("{}: unexpected end of file, expected {}", where(), what)};
    if (!parse_int(t, v)) return Error{fmt::format("{}: expected {} (an integer), found '{}'", where(), what, printable(t))};
    return {};
  };
  // A count of `per`-item lists the rest of the section must hold: each item takes at least 4
  // bytes in binary, 2 in text ("1 ").
  const auto count = [&](long long& v, const char* what, long long per = 1) -> Status {
    if (Status st = integer(v, what, false); !st) return st;
    const double most = static_cast<double>(left()) / (binary ? 4.0 : 2.0) / static_cast<double>(per);
    if (v < 0 || static_cast<double>(v) > most)
      return Error{fmt::format("{}: promises {} {}, more than the file can hold", where(),
                               v < 0 ? "a negative number of" : std::to_string(v), what)};
    return {};
  };
  const auto skip = [&](long long n, bool is_int) -> Status {  // n ints, or n doubles when !is_int
    if (binary) {
      const size_t bytes = static_cast<size_t>(n) * (is_int ? 4 : 8);
      if (!bin.fits(bytes)) return Error{fmt::format("{}: unexpected end of file", where())};
      bin.at += bytes;
      return {};
    }
    for (long long i = 0; i < n; ++i) {
      std::string_view t;
      if (!in.next(t)) return Error{fmt::format("{}: unexpected end of file", where())};
      long long k = 0;
      double x = 0;
      if (is_int ? !parse_int(t, k) : !parse_double(t, x))
        return Error{fmt::format("{}: expected {}, found '{}'", where(), is_int ? "an integer" : "a number", printable(t))};
    }
    return {};
  };
  long long v = 0;
  if (partitioned) {
    long long partitions = 0, ghosts = 0;
    if (Status st = integer(partitions, "the number of partitions", false); !st) return st;
    if (Status st = count(ghosts, "ghost entities", 2); !st) return st;
    if (Status st = skip(2 * ghosts, true); !st) return st;
  }
  long long entities[4] = {0, 0, 0, 0};
  constexpr const char* kinds[4] = {"points", "curves", "surfaces", "volumes"};
  for (int d = 0; d < 4; ++d)
    if (Status st = count(entities[d], kinds[d]); !st) return st;
  for (int d = 0; d < 4; ++d)
    for (long long e = 0; e < entities[d]; ++e) {
      if (Status st = integer(v, "an entity tag", true); !st) return st;
      if (partitioned) {
        if (Status st = skip(2, true); !st) return st;  // parent dimension and tag
        if (Status st = count(v, "partitions of an entity"); !st) return st;
        if (Status st = skip(v, true); !st) return st;
      }
      // A point's coordinates (format 4.1) or an entity's box.
      if (Status st = skip(d == 0 && (binary || version >= 4.1) ? 3 : 6, false); !st) return st;
      if (Status st = count(v, "physical tags of an entity"); !st) return st;
      if (Status st = skip(v, true); !st) return st;
      if (d > 0) {
        if (Status st = count(v, "bounding entities of an entity"); !st) return st;
        if (Status st = skip(v, true); !st) return st;
      }
    }
  used = binary ? bin.at : in.position();
  return {};
}

// Gmsh sizes memory by the counts and tag ranges a file promises, before reading what follows:
// a damaged file promising billions of nodes (or a node tag of 10^12 in format 4) would have it
// allocate terabytes or crash. Check those promises against the file's size first.
// The four numbers after a section's name line, which ends just before byte `at` of the file `t`:
// size_t in a binary v4 file, text otherwise. How many were read (sscanf's count for text).
int section_counts(const std::string& t, size_t at, bool binary_v4, double (&v)[4]) {
  v[0] = v[1] = v[2] = v[3] = 0;
  if (binary_v4) {
    if (at + 32 > t.size()) return 0;
    for (int k = 0; k < 4; ++k) {
      std::uint64_t x = 0;
      std::memcpy(&x, t.data() + at + 8 * k, 8);
      v[k] = static_cast<double>(x);
    }
    return 4;
  }
  return std::sscanf(t.c_str() + at, "%lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3]);
}

// A count or tag read as a double, for messages: whole digits up to 10^15, then 3 significant ones.
std::string number_shown(double v) {
  return std::fabs(v) < 1e15 ? fmt::format("{:.0f}", v) : fmt::format("{:.3g}", v);
}

// Format 4: the file read as Gmsh 4.8's reader for it (GModel::_readMSH4) reads it: sections found
// as for format 2 but by 1023-byte fgets reads, and a section ending at the first line, after what
// its reader read, whose bytes from the second on open "End<name>" (measured on Gmsh 4.8.4: a
// '$MeshFormat' inside an unknown section is not read, one 1023 bytes into a line is). Each section
// Gmsh reads is walked from where Gmsh starts reading it to where it stops (found by fuzzing: a
// "$Entities\x14\0\0\0" line, which an exact-name scan passed over, made Gmsh ask for 3e18 bytes).
// Checked on the way: the byte-order int; every count against the file's size; tags within their
// promised ranges; each entity's counts (check_msh4_entities); each $Nodes and $Elements block
// against the section's totals, every element's nodes within the $Nodes range. Format 4.0 and
// the sections palpate does not walk ($Periodic, $GhostElements, $Parametrizations, views) are
// refused.
Status check_msh4(const std::string& t, double max_count, const std::string& name) {
  StdioWalk f(t, 1023);
  std::string str = "x";
  double version = 1.0;  // until $MeshFormat says (at least 4.1)
  bool binary = false;
  // Generous bound on tags: sparse, but not by more than a factor 64 of the file's size.
  const double max_tag = std::max(1e6, 64.0 * static_cast<double>(t.size()));
  std::uint64_t node_min = 0, node_max = 0;  // tag range of $Nodes, for the elements' nodes
  const auto error = [&](int line, const std::string& what) { return Error{fmt::format("{}:{}: {}", name, line, what)}; };
  while (true) {
    while (str.empty() || str[0] != '$')
      if (!f.gets(str) || f.eof()) break;
    if (f.eof()) break;
    const std::string section(after_first(str));
    const std::string end = "End" + section;
    const std::string shown = section_shown(section);
    const int line = f.gets_line();
    const bool walks = starts(section, "Entities") || starts(section, "PartitionedEntities") ||
                       starts(section, "Nodes") || starts(section, "Elements");
    if (walks && version < 4.1)  // Gmsh would read it in another layout
      return error(line, fmt::format("{} before $MeshFormat", shown));
    const auto walked = [&](Status s, size_t used) -> Status {
      if (!s) return s;
      f.skip(used);
      return {};
    };
    if (starts(section, "MeshFormat")) {
      int format = 0;
      unsigned long size = 0;
      if (!f.gets(str) || f.eof() || std::sscanf(str.c_str(), "%lf %d %lu", &version, &format, &size) != 3)
        return error(line + 1, "expected the version, file type and data size after $MeshFormat");
      if (version < 4.1)
        return error(line + 1, fmt::format("Gmsh mesh format {} is not read; save the mesh in format 4.1 or 2.2", version));
      if (format) {
        binary = true;
        if (Status s = check_byte_order(f, line + 2, name); !s) return s;
        if (size != 8) return error(line + 1, fmt::format("binary mesh with {}-byte sizes; expected 8", size));
      }
    } else if (starts(section, "PhysicalNames")) {
      long long n = 0;
      if (!f.gets(str) || f.eof() || std::sscanf(str.c_str(), "%lld", &n) != 1 || n < 0 ||
          static_cast<double>(n) > max_count)
        return error(line + 1, "expected the number of physical names after $PhysicalNames");
      std::string name_line;
      for (long long i = 0; i < n; ++i) {
        long long dim = 0, tag = 0;
        if (!f.scan_int(dim) || !f.scan_int(tag) || !f.gets(name_line, 255))
          return error(f.token_line(), fmt::format("{}: expected name {} of {} (dimension, tag, \"name\")", shown,
                                                   i + 1, n));
        if (dim < 0 || dim > 3)  // Gmsh indexes a table of four by it
          return error(f.token_line(), fmt::format("{}: dimension {} of name {} is not 0..3", shown, dim, i + 1));
      }
    } else if (starts(section, "Entities") || starts(section, "PartitionedEntities")) {
      const bool partitioned = starts(section, "PartitionedEntities");
      if (!partitioned) {
        // Four counts (points, curves, surfaces, volumes) Gmsh sizes its entity tables by (found by
        // fuzzing: a binary count of 1.3e19 points made it allocate exabytes).
        double v[4];
        const int n = section_counts(t, f.at(), binary, v);
        constexpr const char* kinds[4] = {"points", "curves", "surfaces", "volumes"};
        for (int k = 0; k < n; ++k)
          if (!(v[k] >= 0 && v[k] <= max_count))
            return error(line + 1, fmt::format("$Entities promises {:.0f} {}, more than the file can hold", v[k], kinds[k]));
      }
      size_t used = 0;
      if (Status s = walked(check_msh4_entities(std::string_view(t).substr(f.at()), binary, partitioned, version, line,
                                                name, used),
                            used);
          !s)
        return s;
    } else if (starts(section, "Nodes") || starts(section, "Elements")) {
      const bool nodes = starts(section, "Nodes");
      // Blocks, count, min tag, max tag.
      double v[4];
      const int n = section_counts(t, f.at(), binary, v);
      if (n < 1)  // Gmsh reads on with whatever count it has then (found by fuzzing: '+')
        return error(line + 1, fmt::format("expected the number of {} after {}", nodes ? "nodes" : "elements", shown));
      if (n >= 2 && (v[1] < 0 || v[1] > max_count))
        return error(line + 1, fmt::format("{} promises {:.0f} {}, more than the file can hold", shown, v[1],
                                           nodes ? "nodes" : "elements"));
      if (n == 4 && !(v[2] >= 0 && v[2] <= max_tag && v[3] >= 0 && v[3] <= max_tag))  // NaN too
        return error(line + 1, fmt::format("{} tags run from {} to {}, beyond the file's size (expected 0 to at most "
                                           "{:.0f})",
                                           shown, number_shown(v[2]), number_shown(v[3]), max_tag));
      if (nodes && n == 4) {
        node_min = static_cast<std::uint64_t>(v[2]);
        node_max = static_cast<std::uint64_t>(v[3]);
      }
      const std::string_view body = std::string_view(t).substr(f.at());
      size_t used = 0;
      if (Status s = walked(binary ? check_msh4_binary_block_sums(body, nodes, line, name, node_min, node_max, used)
                                   : check_msh4_block_sums(body, nodes, line, name, node_min, node_max, used),
                            used);
          !s)
        return s;
    } else if (starts(section, "Periodic") || starts(section, "GhostElements") ||
               starts(section, "Parametrizations")) {
      return error(line, fmt::format("{}: not read by palpate; save the mesh without it", shown));
    } else if (starts(section, "NodeData") || starts(section, "ElementData") || starts(section, "ElementNodeData")) {
      // Post-processing views: Gmsh sizes their arrays by counts inside them; palpate has no use for them.
      return error(line, fmt::format("{}: post-processing data is not read; save the mesh without it", shown));
    }
    while (!starts(after_first(str), end))
      if (!f.gets(str) || f.eof()) break;
    str[0] = 'a';
  }
  return {};
}

}  // namespace

Status check_msh_counts(const std::filesystem::path& file) {
  Result<std::string> text = read_whole_file(file);
  if (!text) return text.error();
  const std::string& t = *text;
  const size_t bytes = t.size();
  const std::string name = file.string();
  // The format version Gmsh will read the file as (each walk reads the file type itself).
  double version = 1.0;
  if (!gmsh_version(t, version))
    return Error{fmt::format("{}: expected a $MeshFormat section with the format's version, file type and data size",
                             name)};
  // Generous bounds: a node or element takes at least 4 bytes of text, and tags may be sparse,
  // but not by more than a factor 64 of the file's size.
  const double max_count = static_cast<double>(bytes) / 4.0 + 16;
  if (version < 3) return check_msh2(t, max_count, name);
  if (version < 4)
    return Error{fmt::format("{}: Gmsh mesh format {} (MSH3) is not read; save the mesh in format 4.1 or 2.2", name,
                             version)};
  if (version >= 5) return {};  // Gmsh refuses it with its own message
  return check_msh4(t, max_count, name);
}

}  // namespace palpate::io
