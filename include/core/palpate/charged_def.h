// palpate/charged_def.h — parameters of the charged-particle tissue model (scene-file material).
#pragma once

#include <palpate/params.h>

#include <string>

namespace palpate {

// Material of one charged-particle patch (DESIGN.md §1, docs/models/charged-particles.md). SI units.
// Every key means the same thing at any particle spacing and any tick: the contact force is a
// function of the indentation (not of how many particles sample it, nor of dt).
struct ChargedMaterialDef {
  double max_displacement = 0.005;     // m, farthest a particle may move from its origin (rigidity);
                                       //   the indentation at which a sharp tool punctures the layer
  double elasticity = 20.0;            // 1/s, return rate to origin once released; 0 = stays
  double particle_radius = 0.0011;     // m, sphere of influence = tool radius + this
  double max_strain = 0.5;             // neighbours may be (1 + this) × their rest distance apart
  double max_separation = 0.0;         // m, absolute neighbour distance limit; 0 = from max_strain
  double puncture_force = 1.5;         // N, contact force at max_displacement: a needle punctures
  double linear_share = 0.3;           // share of the linear term at puncture (Okamura a1·x + a2·x²)
  double snap_share = 0.08;            // peak snap of the reversed charges after a puncture, × puncture_force
  double puncture_time = 0.025;        // s, the layer gives way over this time, then snaps over as long
  bool hole_closes = false;            // whether a puncture hole closes once the tool leaves
  bool two_sided = false;              // met from inside too (a vessel wall: punctured in, then out)
  double thickness = 0.003;            // m, the layer's depth below its surface (shaft length in it)
  double friction_per_length = 100.0;  // N/m, kinetic friction per metre of shaft inside the layer
  double friction_presliding = 0.0003; // m, shaft travel over which friction builds (Dahl model)
  // Cutting (docs/models/cutting.md): a blade pressed in past cutting_force parts the links its
  // edge sweeps through; while it cuts, each metre of edge in the layer drags with
  // cutting_drag_per_length; the wound's edges part under the layer's tension to wound_gap.
  double cutting_force = 1.0;          // N, contact force at which a blade starts to cut
  double cutting_drag_per_length = 170.0;  // N/m, drag per metre of edge in the layer while cutting
  double wound_gap = 0.002;            // m, the width a cut opens to under the layer's tension
  double mesh_spacing = 0.001;         // m, particle spacing when the patch is laid on a mesh
  // The contact force: "indentation" (the law Φ(δ) of how far the sphere of influence reaches past
  // the rest surface: the same at any spacing and tick) or "coulomb" (the seed's own sum of the
  // HIP's Coulomb repulsion from the particles in its sphere of influence, for reproducing and
  // comparing the paper: ∝ 1/spacing², its stiffness depends on the tick; the charges below set it).
  std::string force_model = "indentation";
  double particle_charge = 1.0e-8;     // C, each particle's charge (force_model coulomb)
  double hip_charge = 1.0e-8;          // C, the HIP's, like-signed: they repel (force_model coulomb)
};

std::span<const Param<ChargedMaterialDef>> param_table(const ChargedMaterialDef*);

}  // namespace palpate
