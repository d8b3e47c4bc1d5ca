// fill.cpp — filling a closed surface with tetrahedra, in the meshing layer: the Simulation's
// builder calls it and hands the tissue the volume mesh. The options and the surface are checked
// here, the fill is Gmsh's (fill_gmsh.cpp; without Gmsh, fill_none.cpp refuses), and each
// tetrahedron it hands back is oriented and validated here.
#include <palpate/meshing.h>

#include "meshing/fill.h"

#include <fmt/format.h>

#include <cmath>
#include <utility>

namespace palpate {

Result<TetMesh> tetrahedralize(const SurfaceMesh& surface, double max_edge) {
  return tetrahedralize(surface, FillOptions{.max_edge = max_edge, .refine = {}});
}

Result<TetMesh> tetrahedralize(const SurfaceMesh& surface, const FillOptions& options) {
  const std::string where = "tetrahedralize";
  const double max_edge = options.max_edge;
  if (!std::isfinite(max_edge) || max_edge < 0)
    return Error{fmt::format("{}: max_edge is {}, expected 0 (as the surface's edges) or a positive length in m",
                             where, max_edge)};
  for (size_t k = 0; k < options.refine.size(); ++k) {
    const FillRefinement& r = options.refine[k];
    if (!r.center.allFinite())
      return Error{fmt::format("{}: refine[{}].center is ({}, {}, {}), expected a finite point in m", where, k,
                               r.center.x(), r.center.y(), r.center.z())};
    if (!std::isfinite(r.radius) || r.radius < 0)
      return Error{fmt::format("{}: refine[{}].radius is {}, expected a length ≥ 0 in m", where, k, r.radius)};
    if (!std::isfinite(r.size) || r.size <= 0 || (max_edge > 0 && r.size > max_edge))
      return Error{fmt::format("{}: refine[{}].size is {}, expected a length > 0 in m{}", where, k, r.size,
                               max_edge > 0 ? fmt::format(", at most max_edge ({})", max_edge) : std::string())};
    if (!std::isfinite(r.growth) || r.growth <= 0 || r.growth > 10)
      return Error{fmt::format("{}: refine[{}].growth is {}, expected a size gain per metre in (0, 10]", where, k,
                               r.growth)};
  }
  if (Status s = validate(surface, where, SurfaceRequirements{.manifold = true, .closed = true}); !s)
    return s.error();
  Result<TetMesh> mesh = meshing::gmsh_fill(surface, options, where);
  if (!mesh) return mesh;
  // Gmsh's tetrahedra follow its own reference element (positive), but an inward-facing
  // surface may hand back the mirror image: orient each one positively, whatever came out.
  for (Eigen::Index t = 0; t < mesh->T.rows(); ++t) {
    const auto p = [&](int k) -> Vec3 { return mesh->V.row(mesh->T(t, k)).transpose(); };
    if ((p(1) - p(0)).dot((p(2) - p(0)).cross(p(3) - p(0))) < 0) std::swap(mesh->T(t, 2), mesh->T(t, 3));
  }
  if (Status s = validate(*mesh, where); !s) return s.error();
  return mesh;
}

}  // namespace palpate
