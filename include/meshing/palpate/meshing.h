// palpate/meshing.h — meshes made from meshes (the meshing layer, above io): a closed surface
// filled with tetrahedra (Gmsh) and a surface remeshed isotropically (CGAL). Tissue models never
// call these: the Simulation's builder does, and hands the tissue the mesh it made. In a build
// without Gmsh or CGAL (PALPATE_WITH_GMSH, PALPATE_WITH_CGAL OFF) each fails, after its checks, with
// an error naming the option.
#pragma once

#include <palpate/core.h>
#include <palpate/mesh.h>

#include <string>

namespace palpate {

// Fill a closed, manifold surface with tetrahedra (Gmsh's Delaunay mesher). The surface's
// triangles are kept as the boundary (not remeshed); its used vertices come first, in their order.
// `max_edge` (m) bounds the tetrahedra's size, 0 = as the surface's edges. The result is
// validated and positively oriented; an open or non-manifold surface is refused.
Result<TetMesh> tetrahedralize(const SurfaceMesh& surface, double max_edge = 0.0);

// The same fill with a size field: the size at a point is the smallest of max_edge (when > 0) and
// each refinement's size + growth · max(0, distance − radius). Options are checked first (errors
// name the refinement and the field, e.g. "tetrahedralize: refine[0].size is -1, expected ...").
Result<TetMesh> tetrahedralize(const SurfaceMesh& surface, const FillOptions& options);

// Remesh `surface` so its edges are about `target_edge` long (CGAL's isotropic_remeshing, which
// also equalises valences toward 6 and projects the vertices back onto the input surface).
// Boundary edges are only split, never collapsed or smoothed, so an open surface keeps its exact
// boundary polyline and a closed one stays closed. N gets outward unit vertex normals.
// Errors name `where`: non-manifold input, or a closed surface CGAL cannot orient.
Result<SurfaceMesh> remesh_isotropic(const SurfaceMesh& surface, double target_edge, const std::string& where);

}  // namespace palpate
