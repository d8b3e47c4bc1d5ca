// gmsh_session.h — internal: the one Gmsh session palpate keeps (Gmsh has one global model and
// option set), shared by the .msh reader (io) and the tetrahedral fill (meshing). gmsh.h stays in
// the .cpp files that call it. Built without Gmsh (PALPATE_WITH_GMSH=OFF), gmsh_none.cpp defines
// gmsh_read_tets alone, failing; nothing else here is called then.
#pragma once

#include <palpate/mesh.h>

#include <filesystem>
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

// The nodes and tetrahedra of a .msh file (v1, v2, v4) that check_msh_header and check_msh_counts
// passed, read by Gmsh in the session; errors name the file and Gmsh's messages.
Result<TetMesh> gmsh_read_tets(const std::filesystem::path& file);

}  // namespace palpate::io
