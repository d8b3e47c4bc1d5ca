// surface_assimp.cpp — load_surface: OBJ, STL, PLY, OFF (and any other format assimp reads) into a
// merged, validated SurfaceMesh. The only file of palpate that includes assimp's headers.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "core/mesh_topology.h"
#include "io/mesh_io.h"
#include "io/text_lines.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <array>
#include <cstdint>
#include <iterator>
#include <cstring>
#include <fstream>
#include <system_error>
#include <unordered_map>
#include <vector>

namespace palpate {

namespace {

// Vertices are merged by exact position across all meshes of the scene, so a surface whose
// corners carry different normals or UVs, or that a file splits into groups, stays connected.
struct PositionHash {
  size_t operator()(const std::array<float, 3>& p) const {
    size_t h = 0;
    for (float x : p) {
      std::uint32_t bits = 0;
      std::memcpy(&bits, &x, sizeof bits);
      h = h * 1000003u ^ bits;
    }
    return h;
  }
};

// Bytes of a PLY scalar type; 0 for an unknown name.
size_t ply_type_size(std::string_view t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

bool ply_integer_type(std::string_view t) { return ply_type_size(t) > 0 && t.find("float") == std::string_view::npos && t != "double"; }

// assimp 5.2's PLY reader loops forever on a header without "end_header", and trusts the header's
// element counts (a 318-byte cube claiming 100,000,000 vertices ran for a minute and 1.3 GB;
// claiming fewer, it "read" vertices the file does not have): check the header ourselves, and
// every count against what the file holds after it, before handing the file over (as the OFF and
// Gmsh readers do). Each element needs at least one number per property (a list, its count)
// in ASCII, and at least its properties' bytes (a list, its count's) in binary.
//
// It also sizes its vertex and face arrays by the first "vertex" and the first "face" (or
// "tristrips") element and writes every later one's into them: a second, larger "element vertex"
// wrote past the array (found by fuzzing: ASan's heap check failed inside assimp; valgrind showed
// the write), and a face's texture-coordinate list is read against its vertex list. So the header
// must be one assimp and palpate read alike — line 2 the format, then only comment, obj_info,
// element, property (of a known type) and end_header lines, one vertex element before at most one
// face or tristrips element, the face's vertex indices a list — and the body is walked instance by
// instance (ASCII: one line each, every value a number of its type; binary: every list's count
// within the bytes left) before assimp reads it.
Status check_ply_header(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string line;
  int number = 0;
  const auto trimmed = [&line] {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    return line;
  };
  struct Property {
    bool list = false;
    std::string count_type, type, name;
  };
  struct Element {
    std::string name;
    unsigned long long count = 0;
    size_t numbers = 0, bytes = 0;  // at least, per element
    int line = 0;
    std::vector<Property> properties;
  };
  std::vector<Element> elements;
  bool ascii = false, big_endian = false, header_cr = false, properties_open = false;
  const std::string name = file.string();
  const auto error = [&](int at, const std::string& what) { return Error{fmt::format("{}:{}: {}", name, at, what)}; };
  while (std::getline(in, line)) {
    ++number;
    if (number == 1 && trimmed() != "ply") return Error{fmt::format("{}:1: expected the PLY magic line 'ply'", name)};
    if (number == 1) continue;
    // assimp ends a line at '\r', '\0' and '\f' as well as '\n' (a lone '\r' makes two lines of one)
    // and starts a binary body one byte early after a CRLF end_header: such headers are refused.
    const size_t cr = line.find('\r');
    if (line.find('\0') != std::string::npos || line.find('\f') != std::string::npos ||
        (cr != std::string::npos && cr + 1 != line.size()))
      return error(number, "a NUL, form feed or carriage return inside a header line");
    header_cr |= cr != std::string::npos;
    const std::string l = trimmed();
    std::string_view tok[6];
    size_t n = 0;
    for (size_t i = 0; i < l.size() && n < 6;) {
      while (i < l.size() && (l[i] == ' ' || l[i] == '\t')) ++i;
      const size_t start = i;
      while (i < l.size() && l[i] != ' ' && l[i] != '\t') ++i;
      if (i > start) tok[n++] = std::string_view(l).substr(start, i - start);
    }
    if (number == 2) {
      if (n != 3 || tok[0] != "format" ||
          (tok[1] != "ascii" && tok[1] != "binary_little_endian" && tok[1] != "binary_big_endian"))
        return error(2, fmt::format("expected 'format ascii 1.0' (or binary_little_endian, binary_big_endian), found "
                                    "'{}'",
                                    io::printable(l)));
      ascii = tok[1] == "ascii";
      big_endian = tok[1] == "binary_big_endian";
      continue;
    }
    if (n >= 1 && (tok[0] == "comment" || tok[0] == "obj_info")) {
      properties_open = false;  // assimp ends an element's properties at any line that is not one
      continue;
    }
    if (n == 3 && tok[0] == "element") {
      long long count = 0;
      if (!io::parse_int(tok[2], count) || count < 0 || tok[2].front() == '+')  // assimp reads "+6" as 0
        return Error{fmt::format("{}:{}: element {}: expected a count >= 0, found '{}'", name, number,
                                 io::printable(tok[1]), io::printable(tok[2]))};
      // assimp 5.2 reads the count of an element it has no name for from the start of its name
      // (found by fuzzing: "element 6666…6face 12" made it allocate 68 GB; "element camera 1" is 0
      // instances to it, and the rest of the body is misread).
      const bool known = tok[1] == "vertex" || tok[1] == "face" || tok[1] == "tristrips" || tok[1] == "edge" ||
                         tok[1] == "material";
      if (!known && (count != 0 || std::isdigit(static_cast<unsigned char>(tok[1].front())) || tok[1] == "TextureFile"))
        return error(number, fmt::format("element {}: assimp 5.2 reads only vertex, face, tristrips, edge and material "
                                         "elements (others must be empty)",
                                         io::printable(tok[1])));
      const auto seen = [&](std::initializer_list<const char*> names) {
        for (const Element& e : elements)
          for (const char* x : names)
            if (e.name == x) return true;
        return false;
      };
      const bool faces = tok[1] == "face" || tok[1] == "tristrips";
      if (tok[1] == "vertex" && seen({"vertex"}))
        return error(number, "a second 'element vertex' (assimp writes it into the first one's array)");
      if (faces && seen({"face", "tristrips"}))
        return error(number, fmt::format("a second face element '{}' (assimp writes it into the first one's array)",
                                         io::printable(tok[1])));
      if (faces && !seen({"vertex"})) return error(number, "the face element comes before 'element vertex'");
      elements.push_back({std::string(tok[1]), static_cast<unsigned long long>(count), 0, 0, number, {}});
      properties_open = true;
      continue;
    }
    if (tok[0] == "property" && ((n == 3 && tok[1] != "list") || (n == 5 && tok[1] == "list"))) {
      if (elements.empty()) return error(number, "a property before any element");
      if (!properties_open)
        return error(number, "a property after a comment or obj_info line (assimp 5.2 ends the element's properties "
                             "at such a line and drops the rest)");
      const bool list = n == 5;
      const std::string_view type = list ? tok[3] : tok[1];
      if (ply_type_size(type) == 0 || (list && !ply_integer_type(tok[2])))
        return error(number, fmt::format("property '{}': unknown type (expected char, uchar, short, ushort, int, uint, "
                                         "float or double; a list's count an integer type)",
                                         io::printable(l)));
      Element& e = elements.back();
      e.numbers += 1;
      e.bytes += list ? ply_type_size(tok[2]) : ply_type_size(type);
      e.properties.push_back({list, list ? std::string(tok[2]) : "", std::string(type), std::string(list ? tok[4] : tok[2])});
      continue;
    }
    if (l != "end_header")
      return error(number, fmt::format("expected comment, obj_info, element, property or end_header, found '{}'",
                                       io::printable(l)));
    if (!ascii && header_cr) return error(number, "a binary PLY file whose header lines end in CRLF (assimp 5.2 "
                                                  "reads its body from the wrong byte)");
    for (const Element& e : elements)
      if (e.name == "face") {
        bool indices = false;
        for (const Property& p : e.properties) indices |= p.list && (p.name == "vertex_indices" || p.name == "vertex_index");
        if (!indices) return error(e.line, "element face has no 'property list ... vertex_indices'");
      }
    // What follows the header: numbers (ASCII) or bytes (binary).
    const std::string body(std::istreambuf_iterator<char>(in), {});
    unsigned long long have = 0;
    if (ascii) {
      bool in_token = false;
      for (const char c : body) {
        const bool space = c == ' ' || c == '\t' || c == '\n' || c == '\r';
        if (!space && !in_token) ++have;
        in_token = !space;
      }
    } else {
      have = body.size();
    }
    unsigned long long need = 0;
    for (const Element& e : elements) {
      const size_t each = std::max<size_t>(1, ascii ? e.numbers : e.bytes);
      if (e.count > (have - std::min(have, need)) / each)
        return Error{fmt::format("{}:{}: element {} claims {} but the file holds data for at most {} ({} {} after "
                                 "the header)", name, e.line, e.name, e.count,
                                 (have - std::min(have, need)) / each, have, ascii ? "numbers" : "bytes")};
      need += e.count * each;
    }
    // The body, instance by instance: in ASCII one line each.
    size_t at = 0;       // the byte after the header
    int body_line = number;
    std::vector<std::string_view> values;  // ASCII: the tokens of the instance's line
    size_t next_value = 0;
    for (const Element& e : elements) {
      for (unsigned long long i = 0; i < e.count; ++i) {
        const auto bad = [&](const std::string& what) {
          return ascii ? error(body_line, fmt::format("element {} {}: {}", e.name, i, what))
                       : error(e.line, fmt::format("element {} {} (binary, byte {} after the header): {}", e.name, i, at,
                                                   what));
        };
        if (ascii) {
          if (at >= body.size()) {
            ++body_line;
            return bad("unexpected end of file");
          }
          size_t eol = body.find('\n', at);
          if (eol == std::string::npos) eol = body.size();
          std::string_view row = std::string_view(body).substr(at, eol - at);
          if (!row.empty() && row.back() == '\r') row.remove_suffix(1);
          if (row.find_first_of(std::string_view("\r\f\0", 3)) != std::string_view::npos) {
            ++body_line;
            return bad("a NUL, form feed or carriage return inside the line (assimp 5.2 splits the line there)");
          }
          at = eol + 1;
          ++body_line;
          values.clear();
          next_value = 0;
          for (size_t k = 0; k < row.size();) {
            while (k < row.size() && (row[k] == ' ' || row[k] == '\t' || row[k] == '\r')) ++k;
            const size_t start = k;
            while (k < row.size() && row[k] != ' ' && row[k] != '\t' && row[k] != '\r') ++k;
            if (k > start) values.push_back(row.substr(start, k - start));
          }
        }
        // The next ASCII value as an integer (or a number), false when the line has no more.
        const auto ascii_value = [&](bool integer, long long& iv) {
          if (next_value >= values.size()) return false;
          double dv = 0;
          const std::string_view t = values[next_value++];
          return integer ? io::parse_int(t, iv) : io::parse_double(t, dv);
        };
        long long vertex_list = -1, texcoords = -1;
        for (const Property& p : e.properties) {
          long long count = 1;
          if (p.list) {
            if (ascii) {
              if (!ascii_value(true, count) || count < 0)
                return bad(fmt::format("expected the count of list '{}'", p.name));
            } else {
              const size_t size = ply_type_size(p.count_type);
              if (size > body.size() - std::min(at, body.size())) return bad("unexpected end of file");
              unsigned char b[8] = {};
              std::memcpy(b, body.data() + at, size);
              at += size;
              if (big_endian) std::reverse(b, b + size);
              const bool is_signed = p.count_type == "char" || p.count_type == "int8" || p.count_type == "short" ||
                                     p.count_type == "int16" || p.count_type == "int" || p.count_type == "int32";
              std::uint32_t u = 0;
              std::memcpy(&u, b, size);  // little-endian host, as palpate's checks assume
              count = !is_signed ? static_cast<long long>(u)
                      : size == 1 ? static_cast<std::int8_t>(u)
                      : size == 2 ? static_cast<std::int16_t>(u)
                                  : static_cast<std::int32_t>(u);
              if (count < 0) return bad(fmt::format("list '{}' has {} values", p.name, count));
            }
            if (p.name == "vertex_indices" || p.name == "vertex_index") vertex_list = count;
            if (p.name == "texcoord") texcoords = count;
          }
          if (ascii) {
            for (long long k = 0; k < count; ++k) {
              long long v = 0;
              if (!ascii_value(ply_integer_type(p.type), v))
                return bad(fmt::format("expected {} {} value{} for '{}'", count, p.type, count == 1 ? "" : "s", p.name));
            }
          } else {
            const double bytes = static_cast<double>(count) * static_cast<double>(ply_type_size(p.type));
            if (bytes > static_cast<double>(body.size() - std::min(at, body.size())))
              return bad(fmt::format("list '{}' of {} values runs past the end of the file", p.name, count));
            at += static_cast<size_t>(bytes);
          }
        }
        if (ascii && next_value != values.size())
          return bad(fmt::format("{} values on the line, its properties take {}", values.size(), next_value));
        // assimp reads a face's texture coordinates (6 to 8 values) against its vertex list.
        if (texcoords >= 6 && texcoords <= 8 && (texcoords - 1) / 2 >= vertex_list)
          return bad(fmt::format("{} texture coordinates for {} vertex indices", texcoords, vertex_list));
      }
    }
    return {};
  }
  return Error{fmt::format("{}:{}: unexpected end of file, expected 'end_header' to close the PLY header",
                           name, number)};
}

// assimp 5.2's OFF reader silently clamps an out-of-range vertex index to the last vertex, which
// would turn a broken face into a wrong one, and it reads the file in a way of its own: the header's
// counts with comments and line breaks skipped between them, then exactly that many lines for the
// vertices (a comment line there is a vertex at the origin), then lines until it has as many faces
// of 1 to 9 vertices as promised, counting the face total down for every other line — below zero
// (found by fuzzing: comment lines after too few faces made it read 4 billion faces, `palpate info`
// segfaulted). Lines end at '\r', '\n', '\f' or NUL, and are cut at 4,096 bytes. So the file is
// walked as assimp reads it and refused where the two would part: every vertex line three
// numbers, every face line 3 to 9 indices within the vertices, exactly as many as the header says.
Status check_off_indices(const std::filesystem::path& file) {
  Result<std::string> text = io::read_whole_file(file);
  if (!text) return text.error();
  const std::string& t = *text;
  const std::string name = file.string();
  size_t pos = 0;
  const auto line_at = [&](size_t at) {
    return 1 + static_cast<int>(std::count(t.begin(), t.begin() + static_cast<std::ptrdiff_t>(std::min(at, t.size())), '\n'));
  };
  const auto error = [&](size_t at, const std::string& what) {
    return Error{fmt::format("{}:{}: {}", name, line_at(at), what)};
  };
  for (size_t i = 0; i < t.size(); ++i)
    if (t[i] == '\0' || t[i] == '\f' || (t[i] == '\r' && (i + 1 >= t.size() || t[i + 1] != '\n')))
      return error(i, "a NUL, form feed or lone carriage return (assimp 5.2 ends a line there)");
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  // assimp's NextToken: spaces, line ends and whole '#' comment lines.
  const auto next_token = [&] {
    while (true) {
      while (pos < t.size() && space(t[pos])) ++pos;
      if (pos < t.size() && t[pos] == '#') {
        while (pos < t.size() && t[pos] != '\n') ++pos;
        continue;
      }
      return;
    }
  };
  const auto token = [&] {
    const size_t start = pos;
    while (pos < t.size() && !space(t[pos])) ++pos;
    return std::string_view(t).substr(start, pos - start);
  };
  const auto digits = [](std::string_view tok, unsigned long long& v) {  // strtoul10 on a whole token
    if (tok.empty() || tok.size() > 9) return false;
    v = 0;
    for (char c : tok) {
      if (c < '0' || c > '9') return false;
      v = v * 10 + static_cast<unsigned long long>(c - '0');
    }
    return true;
  };
  next_token();
  const size_t header_at = pos;
  const std::string_view magic = token();
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF")
    return error(header_at, "expected the OFF header line 'OFF'");
  if (magic != "OFF" && magic != "COFF" && magic != "NOFF" && magic != "CNOFF" && magic != "STOFF")
    return error(header_at, fmt::format("OFF variant '{}' is not read (expected OFF, COFF, NOFF, CNOFF or STOFF)",
                                        io::printable(magic)));
  unsigned long long counts[3] = {0, 0, 0};
  for (unsigned long long& c : counts) {
    next_token();
    const size_t at = pos;
    if (!digits(token(), c)) return error(at, "expected the counts '<vertices> <faces> <edges>'");
  }
  const unsigned long long nv = counts[0], nf = counts[1];
  if (nv == 0 || nf == 0) return error(header_at, "expected at least one vertex and one face");
  next_token();
  // assimp's GetNextLine from here: a line runs to '\r' or '\n'; the line ends after it are skipped.
  const auto next_line = [&](std::string_view& line, size_t& at) {
    if (pos >= t.size()) return false;
    at = pos;
    size_t e = pos;
    while (e < t.size() && t[e] != '\n' && t[e] != '\r') ++e;
    line = std::string_view(t).substr(pos, e - pos);
    pos = e;
    while (pos < t.size() && (t[pos] == '\n' || t[pos] == '\r')) ++pos;
    return true;
  };
  const auto split = [](std::string_view line, std::string_view* out, size_t capacity) {
    size_t n = 0;
    for (size_t i = 0; i < line.size() && n < capacity;) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      const size_t start = i;
      while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
      if (i > start) out[n++] = line.substr(start, i - start);
    }
    return n;
  };
  std::string_view line, tok[11];
  size_t at = 0;
  for (unsigned long long v = 0; v < nv; ++v) {
    if (!next_line(line, at)) return error(t.size(), fmt::format("unexpected end of file, expected vertex {} of {}", v, nv));
    if (line.size() >= 4096) return error(at, fmt::format("vertex {}: a line of 4,096 bytes or more", v));
    const size_t n = split(line, tok, 3);
    double x = 0;
    if (n < 3 || !io::parse_double(tok[0], x) || !io::parse_double(tok[1], x) || !io::parse_double(tok[2], x))
      return error(at, fmt::format("vertex {} of {}: expected 'x y z', found '{}'", v, nv, io::printable(line)));
  }
  for (unsigned long long f = 0; f < nf; ++f) {
    if (!next_line(line, at)) return error(t.size(), fmt::format("unexpected end of file, expected face {} of {}", f, nf));
    if (line.size() >= 4096) return error(at, fmt::format("face {}: a line of 4,096 bytes or more", f));
    const size_t n = split(line, tok, 11);
    unsigned long long k = 0;
    if (n == 0 || !digits(tok[0], k) || k < 3 || k > 9 || n < k + 1)
      return error(at, fmt::format("face {}: expected '<n> <n vertex indices>' with n from 3 to 9, found '{}'", f,
                                   io::printable(line)));
    for (unsigned long long j = 1; j <= k; ++j) {
      unsigned long long idx = 0;
      long long any = 0;
      if (!digits(tok[j], idx)) {
        if (io::parse_int(tok[j], any))
          return error(at, fmt::format("face {} has vertex index {} out of range [0, {})", f, any, nv));
        return error(at, fmt::format("face {}: expected a vertex index, found '{}'", f, io::printable(tok[j])));
      }
      if (idx >= nv) return error(at, fmt::format("face {} has vertex index {} out of range [0, {})", f, idx, nv));
    }
  }
  return {};
}

// The files assimp may open for a mesh: the mesh itself, and files it names (an OBJ's mtllib)
// only when they are regular files in the mesh's own directory. An `mtllib` naming a FIFO blocked
// `palpate info` forever; /dev/zero was read without end; a path elsewhere is not the mesh's.
// Refused ones are "not found" to assimp, which then goes on without materials (never used).
class MeshDirectoryIO final : public Assimp::DefaultIOSystem {
 public:
  explicit MeshDirectoryIO(const std::filesystem::path& mesh) {
    std::error_code ec;
    mesh_ = std::filesystem::weakly_canonical(mesh, ec);
    if (ec) mesh_ = std::filesystem::absolute(mesh, ec);
  }
  bool Exists(const char* file) const override { return allowed(file) && DefaultIOSystem::Exists(file); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return allowed(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
  }

 private:
  bool allowed(const char* file) const {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path p(file ? file : "");
    if (!fs::is_regular_file(p, ec)) return false;  // follows links: a link to /dev/zero is refused
    const fs::path c = fs::weakly_canonical(p, ec);
    if (ec) return false;
    return c == mesh_ || c.parent_path() == mesh_.parent_path();
  }
  std::filesystem::path mesh_;
};

}  // namespace

Result<SurfaceMesh> load_surface(const std::filesystem::path& file, double scale, const SurfaceRequirements& need) {
  const std::string where = file.string();
  if (Status s = io::check_scale(scale, where); !s) return s.error();
  if (Status s = io::check_readable(file); !s) return s.error();
  std::error_code ec;
  if (std::filesystem::file_size(file, ec) == 0 && !ec) return Error{fmt::format("{}: empty file", where)};

  Assimp::Importer importer;
  importer.SetIOHandler(new MeshDirectoryIO(file));  // the importer owns and deletes it
  // Only the formats palpate documents (docs/scene-format.md) and fuzzes (fuzz/): assimp's other
  // readers (3DS, COLLADA, FBX, glTF, ...) are neither tested nor fuzzed here, so they are refused.
  const std::string ext = io::lower_extension(file);
  if (ext != ".obj" && ext != ".stl" && ext != ".ply" && ext != ".off")
    return Error{fmt::format("{}: unknown surface mesh format '{}', expected .obj, .stl, .ply or .off", where, ext)};
  if (ext == ".ply")
    if (Status s = check_ply_header(file); !s) return s.error();
  if (ext == ".off")
    if (Status s = check_off_indices(file); !s) return s.error();
  // Only positions and faces matter: dropping normals, UVs and colours lets
  // JoinIdenticalVertices merge every corner by position.
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                              aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                  aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                  aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS |
                                  aiComponent_MATERIALS);
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // Read without post-processing first: assimp's own steps assert (and abort the process) on
  // faces a damaged file can produce, such as a face with no indices from a truncated PLY.
  const aiScene* raw = importer.ReadFile(where, 0);
  if (!raw) return Error{fmt::format("{}: assimp could not read the file: {}", where, importer.GetErrorString())};
  if (raw->mNumMeshes == 0 || !raw->mMeshes) return Error{fmt::format("{}: no triangle mesh in the file", where)};
  for (unsigned i = 0; i < raw->mNumMeshes; ++i) {
    const aiMesh* mesh = raw->mMeshes[i];
    if (!mesh || (mesh->mNumFaces > 0 && (!mesh->mFaces || !mesh->mVertices)))
      return Error{fmt::format("{}: mesh {} is incomplete", where, i)};
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices == 0 || !face.mIndices)
        return Error{fmt::format("{}: mesh {} face {} has no vertices (is the file truncated?)", where, i, f)};
      for (unsigned k = 0; k < face.mNumIndices; ++k)
        if (face.mIndices[k] >= mesh->mNumVertices)
          return Error{fmt::format("{}: mesh {} face {} has vertex index {} out of range [0, {})", where, i, f,
                                   face.mIndices[k], mesh->mNumVertices)};
    }
  }
  const aiScene* scene = importer.ApplyPostProcessing(
      aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
      aiProcess_PreTransformVertices | aiProcess_SortByPType);
  if (!scene) return Error{fmt::format("{}: assimp could not process the mesh: {}", where, importer.GetErrorString())};
  if (scene->mNumMeshes == 0 || !scene->mMeshes) return Error{fmt::format("{}: no triangle mesh in the file", where)};

  std::unordered_map<std::array<float, 3>, int, PositionHash> index_of;
  std::vector<std::array<float, 3>> positions;
  std::vector<std::array<int, 3>> triangles;
  for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
    const aiMesh* mesh = scene->mMeshes[i];
    if (!mesh || !mesh->mVertices || !mesh->HasFaces()) continue;
    std::vector<int> merged(mesh->mNumVertices);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      std::array<float, 3> p{mesh->mVertices[v].x, mesh->mVertices[v].y, mesh->mVertices[v].z};
      for (float& x : p)
        if (x == 0.0f) x = 0.0f;  // -0 and +0 are one position
      const auto [it, inserted] = index_of.emplace(p, static_cast<int>(positions.size()));
      if (inserted) positions.push_back(p);
      merged[v] = it->second;
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3 || !face.mIndices) continue;  // points and lines are not surface
      std::array<int, 3> t{};
      for (int k = 0; k < 3; ++k) {
        const unsigned idx = face.mIndices[k];
        if (idx >= mesh->mNumVertices)
          return Error{fmt::format("{}: mesh {} face {} has vertex index {} out of range [0, {})", where, i, f, idx,
                                   mesh->mNumVertices)};
        t[k] = merged[idx];
      }
      triangles.push_back(t);
    }
  }

  SurfaceMesh m;
  m.V.resize(static_cast<Eigen::Index>(positions.size()), 3);
  for (size_t v = 0; v < positions.size(); ++v)
    for (int k = 0; k < 3; ++k) m.V(static_cast<Eigen::Index>(v), k) = scale * static_cast<double>(positions[v][k]);
  m.F.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (size_t f = 0; f < triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) m.F(static_cast<Eigen::Index>(f), k) = triangles[f][k];
  if (Status s = validate(m, where, need); !s) return s.error();

  // The contract is counter-clockwise seen from outside: a closed, consistently oriented surface
  // whose triangles face inward (negative enclosed volume) is turned inside out.
  const topology::EdgeCounts edges = topology::count_edges(topology::sorted_half_edges(m.F));
  if (edges.boundary == 0 && edges.non_manifold == 0 && topology::enclosed_volume(m) < 0)
    for (Eigen::Index f = 0; f < m.F.rows(); ++f) std::swap(m.F(f, 1), m.F(f, 2));
  compute_normals(m);
  return m;
}

}  // namespace palpate
