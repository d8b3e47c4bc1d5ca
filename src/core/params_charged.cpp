// params.cpp — the scene keys of the charged-particle material: type, unit, range, meaning.
#include <palpate/charged_def.h>

namespace palpate {

std::span<const Param<ChargedMaterialDef>> param_table(const ChargedMaterialDef*) {
  using D = ChargedMaterialDef;
  static const Param<D> table[] = {
      {"max_displacement", &D::max_displacement, 1e-6, 1.0, "m",
       "farthest a particle may move from its origin; the indentation at which a needle punctures"},
      {"elasticity", &D::elasticity, 0.0, 1e4, "1/s",
       "rate at which a released particle returns to its origin; 0 = stays where pushed"},
      {"particle_radius", &D::particle_radius, 0.0, 1.0, "m",
       "radius of a particle's charge: sphere of influence = tool radius + particle radius"},
      {"max_strain", &D::max_strain, 1e-3, 10.0, "",
       "neighbours may be (1 + max_strain) x their rest distance apart (the tent's slope)"},
      {"max_separation", &D::max_separation, 0.0, 1.0, "m",
       "absolute limit on the distance between neighbours instead of max_strain; 0 = from max_strain"},
      {"puncture_force", &D::puncture_force, 1e-6, 100.0, "N",
       "contact force at max_displacement, where a needle punctures the layer"},
      {"linear_share", &D::linear_share, 0.0, 1.0, "",
       "share of the linear term in the force at puncture (Okamura's a1 x + a2 x^2; 0 = quadratic)"},
      {"snap_share", &D::snap_share, 0.0, 0.1, "",
       "peak pull of a new hole's reversed charges into the tissue after it gives (the snap), x puncture_force"},
      {"puncture_time", &D::puncture_time, 0.0, 1.0, "s",
       "time over which the force at puncture falls away as the layer gives (smoothstep); the snap takes as long"},
      {"hole_closes", &D::hole_closes, 0, 1, "", "whether a puncture hole closes after the tool leaves"},
      {"two_sided", &D::two_sided, 0, 1, "",
       "whether the layer is also met from inside (a vessel wall: the needle punctures it in, then out)"},
      {"thickness", &D::thickness, 1e-6, 1.0, "m",
       "depth of the layer below its surface: the shaft length in it that friction acts on"},
      {"friction_per_length", &D::friction_per_length, 0.0, 1e5, "N/m",
       "kinetic friction per metre of shaft inside the punctured layer (both ways)"},
      {"friction_presliding", &D::friction_presliding, 1e-7, 0.1, "m",
       "shaft travel over which friction builds to its kinetic value after a reversal (Dahl model)"},
      {"cutting_force", &D::cutting_force, 1e-6, 100.0, "N",
       "contact force at which a blade pressed on the layer starts to cut it (docs/models/cutting.md)"},
      {"cutting_drag_per_length", &D::cutting_drag_per_length, 0.0, 1e5, "N/m",
       "drag on a cutting blade per metre of its edge inside the layer (scalpel blades in gel: 0.16-0.19 N/mm, doi:10.1177/0954405414567928)"},
      {"wound_gap", &D::wound_gap, 0.0, 0.05, "m",
       "the width a cut opens to as the layer's tension pulls its edges apart"},
      {"mesh_spacing", &D::mesh_spacing, 1e-6, 1.0, "m",
       "target particle spacing when the patch is laid on a mesh (isotropic remeshing)"},
      {"force_model", &D::force_model, 0, 0, "",
       "the contact force: a law of the indentation, or the seed paper's Coulomb sum over the particles "
       "(grows as 1/spacing^2, stiffness depends on the tick)",
       "indentation|coulomb"},
      {"particle_charge", &D::particle_charge, 1e-15, 1.0, "C", "each particle's charge (force_model: coulomb)"},
      {"hip_charge", &D::hip_charge, 1e-15, 1.0, "C",
       "the haptic interaction point's charge, like-signed: it repels the particles (force_model: coulomb)"},
  };
  return table;
}

}  // namespace palpate
