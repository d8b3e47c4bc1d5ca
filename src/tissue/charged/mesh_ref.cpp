// mesh_ref.cpp — a charged-particle patch laid on the surface mesh a scene file names.
#include <palpate/mesh_load.h>
#include "tissue/charged/mesh_ref.h"

namespace palpate::charged {

Result<ChargedModel> build_on_mesh_ref(const MeshRef& ref, const ChargedMaterialDef& material,
                                       const std::string& where) {
  Result<SurfaceMesh> surface = load_surface(ref.file, ref.scale, SurfaceRequirements{.manifold = true});
  if (!surface) return Error{where + ": " + surface.error().message};
  surface->V.rowwise() += ref.translate.transpose();
  return build_charged_on_mesh(*surface, material, where + ": mesh '" + ref.file.string() + "'");
}

}  // namespace palpate::charged
