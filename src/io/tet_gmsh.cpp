// tet_gmsh.cpp — reading a Gmsh .msh file (v1, v2, v4): checked first (io/msh_check.h), then read by
// Gmsh in its one session (io/gmsh_session.h; without Gmsh, gmsh_none.cpp refuses it).
#include "io/gmsh_session.h"
#include "io/mesh_io.h"
#include "io/msh_check.h"

#include <fmt/format.h>

namespace palpate::io {

Result<TetMesh> read_gmsh(const std::filesystem::path& file) {
  const std::string where = file.string();
  if (Status s = check_msh_header(file); !s) return s.error();
  if (Status s = check_msh_counts(file); !s) return s.error();
  // Gmsh parses any file not starting with '$' as a .geo script (which can run commands): only a
  // file the checks passed reaches it.
  Result<TetMesh> mesh = gmsh_read_tets(file);
  if (!mesh) return mesh.error();
  if (mesh->T.rows() == 0)
    return Error{fmt::format("{}: no tetrahedra (Gmsh element type 4) in the mesh", where)};
  return mesh;
}


}  // namespace palpate::io
