// tet_load.cpp — load_tet: dispatch to the tetrahedral readers by extension, then scale and validate;
// file helpers shared by all mesh loaders.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "io/mesh_io.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>
#include <system_error>

namespace palpate {

namespace io {

std::string lower_extension(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

Status check_readable(const std::filesystem::path& file) {
  if (Status s = check_regular_file(file, "a mesh file"); !s) return s.error();
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{fmt::format("{}: cannot open the file for reading", file.string())};
  return {};
}

Result<std::string> read_whole_file(const std::filesystem::path& file) {
  if (Status s = check_readable(file); !s) return s.error();
  std::ifstream in(file, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return Error{fmt::format("{}: read error", file.string())};
  if (text.empty()) return Error{fmt::format("{}: empty file", file.string())};
  return text;
}

Status check_scale(double scale, const std::string& where) {
  if (!std::isfinite(scale) || scale <= 0)
    return Error{fmt::format("{}: scale is {}, expected a positive finite factor", where, scale)};
  return {};
}

}  // namespace io

Result<TetMesh> load_tet(const std::filesystem::path& file, double scale) {
  const std::string where = file.string();
  if (Status s = io::check_scale(scale, where); !s) return s.error();
  const std::string ext = io::lower_extension(file);
  Result<TetMesh> mesh = Error{""};
  if (ext == ".msh") {
    if (Status s = io::check_readable(file); !s) return s.error();
    std::error_code ec;
    if (std::filesystem::file_size(file, ec) == 0 && !ec) return Error{fmt::format("{}: empty file", where)};
    mesh = io::read_gmsh(file);
  } else if (ext == ".node" || ext == ".ele") {
    mesh = io::read_tetgen(file);
  } else if (ext == ".vtk") {
    mesh = io::read_vtk(file);
  } else {
    return Error{fmt::format("{}: unknown tetrahedral mesh format '{}', expected .msh, .node, .ele or .vtk", where,
                             ext)};
  }
  if (!mesh) return mesh;
  mesh->V *= scale;
  if (Status s = validate(*mesh, where); !s) return s.error();
  return mesh;
}

}  // namespace palpate
