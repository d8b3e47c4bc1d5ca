// fill_gmsh.cpp — the tetrahedral fill's Gmsh side (meshing/fill.h): Gmsh's Delaunay mesher
// fills a checked closed surface. Built with PALPATE_WITH_GMSH; fill_none.cpp replaces it without.
#include "meshing/fill.h"

#include "io/gmsh_session.h"

#include <gmsh.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace palpate::meshing {
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

}  // namespace

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


}  // namespace palpate::meshing
