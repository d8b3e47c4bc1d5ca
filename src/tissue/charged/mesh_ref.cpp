// mesh_ref.cpp — a charged-particle patch laid on the surface mesh a scene file names.
#include "tissue/charged/mesh_ref.h"

namespace palpate::charged {

Result<ChargedModel> build_on_mesh_ref(const MeshRef& ref, const ChargedMaterialDef& material,
                                       const std::string& where, const TissueServices& services) {
  if (!services.load_surface) return Error{where + ": mesh '" + ref.file.string() + "': no surface loader was handed to the tissue's builder"};
  Result<SurfaceMesh> surface = services.load_surface(ref.file, ref.scale, SurfaceRequirements{.manifold = true});
  if (!surface) return Error{where + ": " + surface.error().message};
  surface->V.rowwise() += ref.translate.transpose();
  return build_charged_on_mesh(*surface, material, where + ": mesh '" + ref.file.string() + "'", services);
}

}  // namespace palpate::charged
