// tet_tetgen.cpp — reader of TetGen's .node/.ele pair (https://wias-berlin.de/software/tetgen/fformats.html).
#include "io/mesh_io.h"
#include "io/text_lines.h"

#include <fmt/format.h>

#include <algorithm>

namespace palpate::io {

namespace {

constexpr size_t kMaxTokens = 64;

struct Lines {
  Lines(const std::string& file_name, std::string_view text) : name(file_name), reader(text, '#') {}
  const std::string& name;
  TokenReader reader;
  std::string_view tok[kMaxTokens];
  size_t count = 0, total = 0;

  Error error(const std::string& what) const {
    return Error{fmt::format("{}:{}: {}", name, reader.line(), what)};
  }
};

// Reads a header or record line; false (with `err`) at end of file.
bool next_record(Lines& in, const char* expected, Error& err) {
  if (!in.reader.line_tokens(in.tok, kMaxTokens, in.count, in.total)) {
    err = Error{fmt::format("{}:{}: unexpected end of file, expected {}", in.name,
                            in.reader.current_line(), expected)};
    return false;
  }
  return true;
}

bool get_int(const Lines& in, size_t i, const char* what, long long& v, Error& err) {
  if (i >= in.count || !parse_int(in.tok[i], v)) {
    err = in.error(fmt::format("expected {} (an integer) as value {}, found '{}'", what, i + 1,
                               i < in.count ? printable(in.tok[i]) : std::string()));
    return false;
  }
  return true;
}

}  // namespace

Result<TetMesh> read_tetgen(const std::filesystem::path& file) {
  std::filesystem::path node_file = file, ele_file = file;
  node_file.replace_extension(".node");
  ele_file.replace_extension(".ele");
  for (const auto& f : {node_file, ele_file})
    if (Status s = check_readable(f); !s) return s.error();
  Result<std::string> node_text = read_whole_file(node_file);
  if (!node_text) return node_text.error();
  Result<std::string> ele_text = read_whole_file(ele_file);
  if (!ele_text) return ele_text.error();

  TetMesh mesh;
  Error err;
  long long base = 0, num_points = 0;
  {
    const std::string name = node_file.string();
    Lines in(name, *node_text);
    // Header: <# of points> <dimension (3)> <# of attributes> <boundary markers (0 or 1)>
    if (!next_record(in, "the header '<points> 3 <attributes> <boundary markers>'", err)) return err;
    long long dim = 3, num_attr = 0, markers = 0;
    if (!get_int(in, 0, "the number of points", num_points, err)) return err;
    if (in.count > 1 && !get_int(in, 1, "the dimension", dim, err)) return err;
    if (in.count > 2 && !get_int(in, 2, "the number of attributes", num_attr, err)) return err;
    if (in.count > 3 && !get_int(in, 3, "the boundary marker flag", markers, err)) return err;
    if (num_points <= 0) return in.error(fmt::format("expected a positive number of points, found {}", num_points));
    if (dim != 3) return in.error(fmt::format("expected dimension 3, found {}", dim));
    if (num_attr < 0 || num_attr > 1000) return in.error(fmt::format("expected 0 to 1000 attributes, found {}", num_attr));
    if (markers != 0 && markers != 1) return in.error(fmt::format("expected boundary marker flag 0 or 1, found {}", markers));
    // Never trust a count to size memory: each point needs at least 8 bytes of text.
    if (static_cast<size_t>(num_points) > node_text->size() / 8 + 1)
      return in.error(fmt::format("the header promises {} points, more than the file can hold", num_points));
    mesh.V.resize(num_points, 3);
    const size_t needed = static_cast<size_t>(4 + num_attr + markers);
    for (long long i = 0; i < num_points; ++i) {
      if (!next_record(in, fmt::format("point {} of {}", i + 1, num_points).c_str(), err)) return err;
      if (in.total < needed)
        return in.error(fmt::format("expected {} values (number, x, y, z{}{}), found {}", needed,
                                    num_attr ? ", attributes" : "", markers ? ", boundary marker" : "", in.total));
      long long number = 0;
      if (!get_int(in, 0, "the point number", number, err)) return err;
      if (i == 0) {
        if (number != 0 && number != 1) return in.error(fmt::format("expected the first point to be numbered 0 or 1, found {}", number));
        base = number;
      } else if (number != base + i) {
        return in.error(fmt::format("expected point number {}, found {}", base + i, number));
      }
      for (int k = 0; k < 3; ++k) {
        double x = 0;
        if (!parse_double(in.tok[1 + k], x))
          return in.error(fmt::format("expected coordinate {} of point {} (a number), found '{}'", "xyz"[k], number, printable(in.tok[1 + k])));
        mesh.V(i, k) = x;
      }
    }
  }
  {
    const std::string name = ele_file.string();
    Lines in(name, *ele_text);
    // Header: <# of tetrahedra> <nodes per tetrahedron (4 or 10)> <region attribute (0 or 1)>
    if (!next_record(in, "the header '<tetrahedra> <nodes per tetrahedron> <region attribute>'", err)) return err;
    long long num_tets = 0, per = 4, region = 0;
    if (!get_int(in, 0, "the number of tetrahedra", num_tets, err)) return err;
    if (in.count > 1 && !get_int(in, 1, "the nodes per tetrahedron", per, err)) return err;
    if (in.count > 2 && !get_int(in, 2, "the region attribute flag", region, err)) return err;
    if (num_tets <= 0) return in.error(fmt::format("expected a positive number of tetrahedra, found {}", num_tets));
    if (per != 4 && per != 10) return in.error(fmt::format("expected 4 or 10 nodes per tetrahedron, found {}", per));
    if (region != 0 && region != 1) return in.error(fmt::format("expected region attribute flag 0 or 1, found {}", region));
    if (static_cast<size_t>(num_tets) > ele_text->size() / 10 + 1)
      return in.error(fmt::format("the header promises {} tetrahedra, more than the file can hold", num_tets));
    mesh.T.resize(num_tets, 4);
    const size_t needed = static_cast<size_t>(1 + per + region);
    for (long long t = 0; t < num_tets; ++t) {
      if (!next_record(in, fmt::format("tetrahedron {} of {}", t + 1, num_tets).c_str(), err)) return err;
      if (in.total < needed)
        return in.error(fmt::format("expected {} values (number, {} nodes{}), found {}", needed, per,
                                    region ? ", region" : "", in.total));
      // Only the four corners are kept; the six mid-edge nodes of a quadratic element follow them.
      for (int k = 0; k < 4; ++k) {
        long long node = 0;
        if (!get_int(in, 1 + k, "a node number", node, err)) return err;
        if (node < base || node >= base + num_points)
          return in.error(fmt::format("tetrahedron {} has node {}, expected a node number in [{}, {})",
                                      t + base, node, base, base + num_points));
        mesh.T(t, k) = static_cast<int>(node - base);
      }
    }
  }
  return mesh;
}

}  // namespace palpate::io
