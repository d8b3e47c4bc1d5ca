// factory.cpp — make_tissue: picks the model a scene's tissue names.
#include "tissue/factory.h"

namespace palpate {

Result<std::unique_ptr<Tissue>> make_tissue(const SceneDef& scene, int index, const TissueServices& services) {
  const TissueDef& t = scene.tissues.at(static_cast<size_t>(index));
  if (t.model == "charged_particles") return make_charged_tissue(scene, index, services);
  if (t.model == "mass_spring") return make_spring_tissue(scene, index, services);
  return Error{scene.file.string() + ":" + std::to_string(t.line) + ": tissue '" + t.name +
               "': unknown model '" + t.model + "' (expected charged_particles or mass_spring)"};
}

void link_layers(std::span<Tissue* const> tissues) {
  for (size_t i = 0; i < tissues.size(); ++i)
    if (tissues[i]) tissues[i]->set_layers_above(tissues.first(i));
}

}  // namespace palpate
