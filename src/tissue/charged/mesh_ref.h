// mesh_ref.h — internal: a charged-particle patch laid on the surface a scene's MeshRef names.
#pragma once

#include <palpate/charged.h>

#include <string>

namespace palpate::charged {

// services.load_surface(ref.file, ref.scale), translated by ref.translate, then build_charged_on_mesh.
// Errors from the loader already name the file; `where` names the scene's tissue.
Result<ChargedModel> build_on_mesh_ref(const MeshRef& ref, const ChargedMaterialDef& material,
                                       const std::string& where, const TissueServices& services);

}  // namespace palpate::charged
