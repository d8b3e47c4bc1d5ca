// gmsh_none.cpp — the .msh reader's Gmsh side in a build without Gmsh (PALPATE_WITH_GMSH=OFF;
// src/CMakeLists.txt): the file passed palpate's own checks, and nothing here can read it.
#include "core/components.h"
#include "io/gmsh_session.h"

namespace palpate::io {

Result<TetMesh> gmsh_read_tets(const std::filesystem::path& file) {
  return built_without(file.string(), "Gmsh", "GMSH",
                       "cannot read a Gmsh .msh mesh (TetGen .node/.ele and VTK .vtk meshes read without it)");
}

}  // namespace palpate::io
