// gmsh_session.h — internal: the one Gmsh session palpate keeps (Gmsh has one global model and
// option set), shared by the .msh reader (io) and the tetrahedral fill (meshing). gmsh.h stays in
// the .cpp files that call it.
#pragma once

#include <palpate/mesh.h>

#include <functional>
#include <string>

namespace palpate::io {

inline constexpr int kGmshTriangle = 2;     // Gmsh element type: 3-node triangle
inline constexpr int kGmshTetrahedron = 4;  // Gmsh element type: 4-node tetrahedron

// Runs `work` on Gmsh under the session's lock (initialising Gmsh once, silent, errors logged
// rather than thrown) with message capture; returns Gmsh's error messages joined ("" = none).
// After an exception out of Gmsh it finalises the session, so the next call starts afresh.
std::string run_gmsh(const std::function<void()>& work);

// Inside run_gmsh's work: the nodes (sorted by tag) and tetrahedra (sorted by element tag) of
// Gmsh's current model.
Result<TetMesh> current_tets(const std::string& where);

}  // namespace palpate::io
