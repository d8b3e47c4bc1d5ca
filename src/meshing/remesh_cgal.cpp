// remesh_cgal.cpp — CGAL isotropic remeshing of a surface (palpate/meshing.h; the only
// file that includes CGAL). Built with PALPATE_WITH_CGAL; remesh_none.cpp replaces it without.
#include <palpate/meshing.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <unordered_map>
#include <vector>

namespace palpate {

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using CgalMesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;
}  // namespace

Result<SurfaceMesh> remesh_isotropic(const SurfaceMesh& surface, double target_edge,
                                     const std::string& where) {
  std::vector<Point> points;
  points.reserve(static_cast<size_t>(surface.V.rows()));
  for (Eigen::Index i = 0; i < surface.V.rows(); ++i)
    points.emplace_back(surface.V(i, 0), surface.V(i, 1), surface.V(i, 2));
  std::vector<std::array<std::size_t, 3>> polygons;
  polygons.reserve(static_cast<size_t>(surface.F.rows()));
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
    polygons.push_back({static_cast<std::size_t>(surface.F(f, 0)), static_cast<std::size_t>(surface.F(f, 1)),
                        static_cast<std::size_t>(surface.F(f, 2))});
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons))
    return Error{where + ": the surface is not an oriented manifold (an edge is shared by more than two "
                         "triangles, or two triangles sharing an edge disagree in orientation); "
                         "expected a manifold surface to lay particles on"};
  CgalMesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  if (CGAL::is_closed(mesh) && !PMP::is_outward_oriented(mesh)) PMP::reverse_face_orientations(mesh);

  // Boundary edges count as constraints: split only (collapse_constraints false), never smoothed,
  // so the boundary polyline is kept exactly; everything else is remeshed and projected back.
  PMP::isotropic_remeshing(faces(mesh), target_edge, mesh,
                           PMP::parameters::number_of_iterations(5).collapse_constraints(false));
  mesh.collect_garbage();

  auto vnormals = mesh.add_property_map<CgalMesh::Vertex_index, Kernel::Vector_3>(
                          "v:palpate_normal", CGAL::NULL_VECTOR).first;
  PMP::compute_vertex_normals(mesh, vnormals);

  SurfaceMesh out;
  out.V.resize(static_cast<Eigen::Index>(mesh.number_of_vertices()), 3);
  out.N.resize(out.V.rows(), 3);
  std::unordered_map<std::uint32_t, int> index;  // Surface_mesh index → dense row (after garbage collection they coincide)
  int row = 0;
  for (CgalMesh::Vertex_index v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    out.V.row(row) << p.x(), p.y(), p.z();
    const Kernel::Vector_3& n = vnormals[v];
    out.N.row(row) << n.x(), n.y(), n.z();
    index[static_cast<std::uint32_t>(v)] = row++;
  }
  out.F.resize(static_cast<Eigen::Index>(mesh.number_of_faces()), 3);
  row = 0;
  for (CgalMesh::Face_index f : mesh.faces()) {
    int k = 0;
    for (CgalMesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      if (k < 3) out.F(row, k++) = index[static_cast<std::uint32_t>(v)];
    if (k != 3) return Error{where + ": remeshing produced a face that is not a triangle"};
    ++row;
  }
  return out;
}

}  // namespace palpate
