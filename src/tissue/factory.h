// factory.h — internal constructors of each tissue model, called by make_tissue.
#pragma once

#include <palpate/tissue.h>

namespace palpate {
Result<std::unique_ptr<Tissue>> make_charged_tissue(const SceneDef& scene, int index, const TissueServices& services);
Result<std::unique_ptr<Tissue>> make_spring_tissue(const SceneDef& scene, int index, const TissueServices& services);
}  // namespace palpate
