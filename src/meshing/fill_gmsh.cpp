// fill_gmsh.cpp — filling a closed surface with tetrahedra (Gmsh's Delaunay mesher), in the
// meshing layer: the Simulation's builder calls it and hands the tissue the volume mesh.
#include <palpate/meshing.h>

#include "io/gmsh_session.h"

#include <gmsh.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace palpate {
namespace {

// The fill's size at a point: the smallest of each refinement's graded size (FillOptions).
double refined_size(const FillOptions& o, double x, double y, double z) {
  double size = o.max_edge > 0 ? o.max_edge : 1e22;
  for (const FillRefinement& r : o.refine) {
    const double d = (Vec3(x, y, z) - r.center).norm();
    size = std::min(size, r.size + r.growth * std::max(0.0, d - r.radius));
  }
  return size;
}

// Gmsh's Delaunay mesher fills the volume bounded by the surface's own triangles (kept as a
// discrete surface, not remeshed), adding interior nodes as Mesh.MeshSizeMax and, with
// refinements, a size callback (the smaller of it and the sizes interpolated from the boundary's
// edges) demand.
Result<TetMesh> gmsh_fill(const SurfaceMesh& surface, const FillOptions& options, const std::string& where) {
  const double max_edge = options.max_edge;
  // Only the vertices the triangles use go to Gmsh: it would keep stray nodes in the surface.
  std::vector<int> new_index(static_cast<size_t>(surface.V.rows()), -1);
  std::vector<double> coords;
  std::vector<std::size_t> node_tags, tri_nodes;
  tri_nodes.reserve(static_cast<size_t>(surface.F.size()));
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int& n = new_index[static_cast<size_t>(surface.F(f, k))];
      if (n < 0) {
        n = static_cast<int>(node_tags.size());
        node_tags.push_back(node_tags.size() + 1);
        for (int d = 0; d < 3; ++d) coords.push_back(surface.V(surface.F(f, k), d));
      }
      tri_nodes.push_back(static_cast<std::size_t>(n) + 1);
    }
  std::vector<std::size_t> tri_tags(static_cast<size_t>(surface.F.rows()));
  std::iota(tri_tags.begin(), tri_tags.end(), std::size_t{1});

  Result<TetMesh> mesh = Error{""};
  const std::string errors = io::run_gmsh([&] {
    gmsh::model::add("palpate_tetrahedralize");
    const int surf = gmsh::model::addDiscreteEntity(2);
    gmsh::model::mesh::addNodes(2, surf, node_tags, coords);
    gmsh::model::mesh::addElementsByType(surf, io::kGmshTriangle, tri_tags, tri_nodes);
    const int loop = gmsh::model::geo::addSurfaceLoop({surf});
    gmsh::model::geo::addVolume({loop});
    gmsh::model::geo::synchronize();
    gmsh::option::setNumber("Mesh.MeshSizeMax", max_edge > 0 ? max_edge : 1e22);  // 1e22: Gmsh's default
    if (!options.refine.empty())
      gmsh::model::mesh::setSizeCallback(
          [&options](int, int, double x, double y, double z) { return refined_size(options, x, y, z); });
    try {
      gmsh::model::mesh::generate(3);
    } catch (...) {
      gmsh::model::mesh::removeSizeCallback();
      gmsh::option::setNumber("Mesh.MeshSizeMax", 1e22);
      throw;
    }
    gmsh::model::mesh::removeSizeCallback();
    gmsh::option::setNumber("Mesh.MeshSizeMax", 1e22);
    mesh = io::current_tets(where);
  });
  if (!errors.empty()) return Error{fmt::format("{}: Gmsh could not fill the surface with tetrahedra: {}", where, errors)};
  if (!mesh) return mesh.error();
  if (mesh->T.rows() == 0) return Error{fmt::format("{}: Gmsh produced no tetrahedra", where)};
  return mesh;
}

}  // namespace

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
  Result<TetMesh> mesh = gmsh_fill(surface, options, where);
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
