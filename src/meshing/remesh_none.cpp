// remesh_none.cpp — isotropic remeshing in a build without CGAL (PALPATE_WITH_CGAL=OFF;
// src/CMakeLists.txt): the same function as remesh_cgal.cpp, refusing.
#include <palpate/meshing.h>

#include "core/components.h"

namespace palpate {

Result<SurfaceMesh> remesh_isotropic(const SurfaceMesh&, double, const std::string& where) {
  return built_without(where, "CGAL", "CGAL", "cannot remesh a surface isotropically (to lay particles on it)");
}

}  // namespace palpate
