// tet_vtk.cpp — reader of legacy ASCII VTK unstructured grids (file format 2.x–5.1), keeping tetrahedra (cell type 10).
#include "io/mesh_io.h"
#include "io/text_lines.h"

#include <fmt/format.h>

#include <vector>

namespace palpate::io {

namespace {

constexpr long long kVtkTetra = 10;  // VTK_TETRA

struct Vtk {
  const std::string& name;
  TokenReader in;
  size_t bytes;  // file size, bounds the counts a header may promise

  Error error(const std::string& what) const { return Error{fmt::format("{}:{}: {}", name, in.line(), what)}; }

  bool token(std::string_view& t, const char* expected, Error& err) {
    if (in.next(t)) return true;
    err = Error{fmt::format("{}:{}: unexpected end of file, expected {}", name, in.current_line(), expected)};
    return false;
  }
  bool integer(long long& v, const char* expected, Error& err) {
    std::string_view t;
    if (!token(t, expected, err)) return false;
    if (parse_int(t, v)) return true;
    err = error(fmt::format("expected {} (an integer), found '{}'", expected, printable(t)));
    return false;
  }
  bool count(long long& v, const char* expected, size_t min_bytes_each, Error& err) {
    if (!integer(v, expected, err)) return false;
    if (v < 0) {
      err = error(fmt::format("expected {} to be 0 or more, found {}", expected, v));
      return false;
    }
    if (static_cast<size_t>(v) > bytes / min_bytes_each + 1) {
      err = error(fmt::format("{} is {}, more than the file can hold", expected, v));
      return false;
    }
    return true;
  }
};

bool is_section(std::string_view t) {
  return t == "POINTS" || t == "CELLS" || t == "CELL_TYPES" || t == "POINT_DATA" || t == "CELL_DATA" ||
         t == "FIELD" || t == "METADATA";
}

}  // namespace

Result<TetMesh> read_vtk(const std::filesystem::path& file) {
  Result<std::string> text = read_whole_file(file);
  if (!text) return text.error();
  const std::string name = file.string();
  Vtk v{name, TokenReader(*text, '\0'), text->size()};
  Error err;

  // Header: "# vtk DataFile Version x.y", a title line, "ASCII", "DATASET UNSTRUCTURED_GRID".
  if (v.in.rest_of_line().substr(0, 22) != "# vtk DataFile Version")
    return Error{fmt::format("{}:1: expected the legacy VTK header '# vtk DataFile Version', found '{}'", name,
                             printable(std::string_view(*text).substr(0, text->find('\n'))))};
  if (!v.in.next_line() || !v.in.next_line())
    return Error{fmt::format("{}:{}: unexpected end of file, expected ASCII or BINARY", name, v.in.current_line())};
  std::string_view t;
  if (!v.token(t, "ASCII", err)) return err;
  if (t == "BINARY") return v.error("binary VTK files are not supported, expected ASCII");
  if (t != "ASCII") return v.error(fmt::format("expected ASCII, found '{}'", printable(t)));
  if (!v.token(t, "DATASET", err)) return err;
  if (t != "DATASET") return v.error(fmt::format("expected DATASET, found '{}'", printable(t)));
  if (!v.token(t, "UNSTRUCTURED_GRID", err)) return err;
  if (t != "UNSTRUCTURED_GRID")
    return v.error(fmt::format("expected DATASET UNSTRUCTURED_GRID, found DATASET {} (only tetrahedral grids are read)", printable(t)));

  TetMesh mesh;
  bool have_points = false, have_cells = false, have_types = false;
  std::vector<long long> offsets;       // (#cells + 1) start of each cell in `connectivity`
  std::vector<long long> connectivity;  // node indices of all cells, 0-based
  std::vector<int> cell_line;           // (#cells) line where each cell starts, for errors
  std::vector<long long> types;         // (#cells) VTK cell types

  while (v.in.next(t)) {
    if (t == "POINTS") {
      long long n = 0;
      if (!v.count(n, "the number of points", 6, err)) return err;
      if (!v.token(t, "the point type", err)) return err;
      if (t != "float" && t != "double")
        return v.error(fmt::format("expected POINTS type float or double, found '{}'", printable(t)));
      mesh.V.resize(n, 3);
      for (long long i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
          if (!v.token(t, "a point coordinate", err)) return err;
          if (!parse_double(t, mesh.V(i, k)))
            return v.error(fmt::format("expected coordinate {} of point {} (a number), found '{}'", "xyz"[k], i, printable(t)));
        }
      have_points = true;
    } else if (t == "CELLS") {
      long long n = 0, size = 0;
      if (!v.count(n, "the number of cells", 2, err)) return err;
      if (!v.count(size, "the cell list size", 2, err)) return err;
      std::string_view look;
      if (v.in.peek(look) && look == "OFFSETS") {
        // File version 5.1: "OFFSETS type" n values, then "CONNECTIVITY type" size values.
        v.in.next(look);
        if (!v.token(t, "the offsets' type", err)) return err;
        offsets.resize(n);
        for (long long i = 0; i < n; ++i)
          if (!v.integer(offsets[i], "a cell offset", err)) return err;
        if (!v.token(t, "CONNECTIVITY", err)) return err;
        if (t != "CONNECTIVITY") return v.error(fmt::format("expected CONNECTIVITY, found '{}'", printable(t)));
        if (!v.token(t, "the connectivity's type", err)) return err;
        connectivity.resize(size);
        const int line = v.in.line();
        for (long long i = 0; i < size; ++i)
          if (!v.integer(connectivity[i], "a cell's point index", err)) return err;
        if (n == 0 || offsets[0] != 0) return v.error("expected the first cell offset to be 0");
        for (long long i = 1; i < n; ++i)
          if (offsets[i] < offsets[i - 1] || offsets[i] > size)
            return v.error(fmt::format("cell offset {} is {}, expected a value in [{}, {}]", i, offsets[i], offsets[i - 1], size));
        cell_line.assign(n - 1, line);
      } else {
        // Up to 5.0: each cell is "<point count> i0 i1 ...", `size` integers in all.
        offsets.assign(1, 0);
        connectivity.clear();
        connectivity.reserve(size);
        cell_line.clear();
        long long read = 0;
        for (long long c = 0; c < n; ++c) {
          long long k = 0;
          if (!v.integer(k, "a cell's point count", err)) return err;
          cell_line.push_back(v.in.line());
          if (k < 0 || read + 1 + k > size)
            return v.error(fmt::format("cell {} has {} points, more than the CELLS size {} allows", c, k, size));
          for (long long j = 0; j < k; ++j) {
            long long idx = 0;
            if (!v.integer(idx, "a cell's point index", err)) return err;
            connectivity.push_back(idx);
          }
          read += 1 + k;
          offsets.push_back(static_cast<long long>(connectivity.size()));
        }
        if (read != size) return v.error(fmt::format("the CELLS size is {}, but the cells hold {} integers", size, read));
      }
      have_cells = true;
    } else if (t == "CELL_TYPES") {
      long long n = 0;
      if (!v.count(n, "the number of cell types", 2, err)) return err;
      types.resize(n);
      for (long long i = 0; i < n; ++i)
        if (!v.integer(types[i], "a cell type", err)) return err;
      have_types = true;
    } else if (t == "POINT_DATA" || t == "CELL_DATA") {
      break;  // attributes follow; the geometry is complete
    } else if (t == "FIELD" || t == "METADATA") {
      // Field data and metadata carry nothing palpate uses: skip to the next section keyword.
      while (v.in.peek(t) && !is_section(t)) v.in.next(t);
    } else {
      return v.error(fmt::format("expected POINTS, CELLS or CELL_TYPES, found '{}'", printable(t)));
    }
  }
  if (!have_points) return Error{fmt::format("{}: no POINTS section", name)};
  if (!have_cells) return Error{fmt::format("{}: no CELLS section", name)};
  if (!have_types) return Error{fmt::format("{}: no CELL_TYPES section", name)};
  const size_t num_cells = offsets.size() - 1;
  if (types.size() != num_cells)
    return Error{fmt::format("{}: CELLS has {} cells but CELL_TYPES has {}", name, num_cells, types.size())};

  size_t num_tets = 0;
  for (long long type : types) num_tets += type == kVtkTetra;
  mesh.T.resize(static_cast<Eigen::Index>(num_tets), 4);
  const long long num_points = mesh.V.rows();
  Eigen::Index row = 0;
  for (size_t c = 0; c < num_cells; ++c) {
    if (types[c] != kVtkTetra) continue;  // triangles, lines, vertices: not part of the volume
    const long long k = offsets[c + 1] - offsets[c];
    if (k != 4)
      return Error{fmt::format("{}:{}: cell {} is a tetrahedron (type 10) with {} points, expected 4", name, cell_line[c], c, k)};
    for (int j = 0; j < 4; ++j) {
      const long long idx = connectivity[offsets[c] + j];
      if (idx < 0 || idx >= num_points)
        return Error{fmt::format("{}:{}: cell {} has point index {} out of range [0, {})", name, cell_line[c], c, idx, num_points)};
      mesh.T(row, j) = static_cast<int>(idx);
    }
    ++row;
  }
  return mesh;
}

}  // namespace palpate::io
