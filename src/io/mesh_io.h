// mesh_io.h — internal: the tetrahedral readers behind load_tet, and helpers shared by the mesh loaders.
#pragma once

#include <palpate/mesh.h>

#include <filesystem>
#include <string>
#include <string_view>

namespace palpate::io {

// Each reader returns the mesh exactly as the file gives it (unscaled, unvalidated apart from
// what the format's own structure demands); load_tet scales and validates.
Result<TetMesh> read_gmsh(const std::filesystem::path& file);    // tet_gmsh.cpp, .msh v1/v2/v4
Result<TetMesh> read_tetgen(const std::filesystem::path& file);  // tet_tetgen.cpp, .node + .ele
Result<TetMesh> read_vtk(const std::filesystem::path& file);     // tet_vtk.cpp, legacy ASCII

// An error when `file` is missing, not a regular file or unreadable; names the file.
Status check_readable(const std::filesystem::path& file);

// The whole file as bytes, or an error naming the file.
Result<std::string> read_whole_file(const std::filesystem::path& file);

// An error when `scale` is not a positive finite number (a negative one would invert the mesh).
Status check_scale(double scale, const std::string& where);

// Lower-case extension with its dot, e.g. ".msh".
std::string lower_extension(const std::filesystem::path& file);

}  // namespace palpate::io
