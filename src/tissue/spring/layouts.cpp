// layouts.cpp — SpringSolverLayouts, the model's opaque holder of the solvers' layouts (layouts.h):
// allocated with the model, deep-copied with it.
#include "tissue/spring/layouts.h"

#include <memory>
#include <utility>

namespace palpate {

SpringSolverLayouts::SpringSolverLayouts() : layouts_(std::make_unique<spring::SolverLayouts>()) {}

SpringSolverLayouts::SpringSolverLayouts(const SpringSolverLayouts& other)
    : layouts_(other.layouts_ ? std::make_unique<spring::SolverLayouts>(*other.layouts_) : nullptr) {
  if (layouts_) layouts_->correction = nullptr;  // the cutter that owns it stays with the original
}

SpringSolverLayouts::SpringSolverLayouts(SpringSolverLayouts&& other) noexcept = default;

SpringSolverLayouts& SpringSolverLayouts::operator=(const SpringSolverLayouts& other) {
  if (this != &other) SpringSolverLayouts(other).layouts_.swap(layouts_);
  return *this;
}

SpringSolverLayouts& SpringSolverLayouts::operator=(SpringSolverLayouts&& other) noexcept = default;

SpringSolverLayouts::~SpringSolverLayouts() = default;

}  // namespace palpate
