// remesh.h — internal: isotropic remeshing of a surface for laying particles on it (CGAL, one .cpp).
#pragma once

#include <palpate/core.h>
#include <palpate/mesh.h>

#include <string>

namespace palpate::charged {

// Remesh `surface` so its edges are about `target_edge` long (CGAL's isotropic_remeshing, which
// also equalises valences toward 6 and projects the vertices back onto the input surface).
// Boundary edges are only split, never collapsed or smoothed, so an open surface keeps its exact
// boundary polyline and a closed one stays closed. N gets outward unit vertex normals.
// Errors name `where`: non-manifold input, or a closed surface CGAL cannot orient.
Result<SurfaceMesh> remesh_isotropic(const SurfaceMesh& surface, double target_edge,
                                     const std::string& where);

}  // namespace palpate::charged
