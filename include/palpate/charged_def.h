// palpate/charged_def.h — parameters of the charged-particle tissue model (scene-file material).
#pragma once

#include <palpate/params.h>

namespace palpate {

// Material of one charged-particle patch (DESIGN.md §1, docs/models/charged-particles.md). SI units.
struct ChargedMaterialDef {
  double max_displacement = 0.005;     // m, farthest a particle may move from its origin (rigidity)
  double elasticity = 20.0;            // 1/s, return rate to origin once released; 0 = stays
  double sphere_of_influence = 0.004;  // m, HIP radius + particle radius: interaction range
  double max_separation = 0.0016;      // m, largest distance allowed between neighbours
  double particle_charge = 1.0e-8;     // C
  double hip_charge = 1.0e-8;          // C, same sign as the particles: they repel
  double puncture_force = 1.5;         // N, force at maximum displacement that punctures
  bool hole_closes = false;            // whether a puncture hole closes once the tool leaves
  double track_friction = 0.3;         // N, kinetic friction of a punctured layer on the tool
  double friction_velocity = 0.001;    // m/s, axial speed at which friction reaches ~76% (tanh)
  double mesh_spacing = 0.001;         // m, particle spacing when the patch is laid on a mesh
};

std::span<const Param<ChargedMaterialDef>> param_table(const ChargedMaterialDef*);

}  // namespace palpate
