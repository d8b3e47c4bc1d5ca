// tissue.cpp — the mass-spring-damper model wired as a scene tissue (being built: issue 5).
#include "tissue/factory.h"

namespace palpate {
Result<std::unique_ptr<Tissue>> make_spring_tissue(const SceneDef&, int) {
  return Error{"the mass-spring model is not built yet"};
}
}  // namespace palpate
