// fill_none.cpp — the tetrahedral fill in a build without Gmsh (PALPATE_WITH_GMSH=OFF;
// src/CMakeLists.txt): tetrahedralize checked the surface, and nothing here can fill it.
#include "core/components.h"
#include "meshing/fill.h"

namespace palpate::meshing {

Result<TetMesh> gmsh_fill(const SurfaceMesh&, const FillOptions&, const std::string& where) {
  return built_without(where, "Gmsh", "GMSH", "cannot fill a surface with tetrahedra");
}

}  // namespace palpate::meshing
