// params.cpp — the scene keys of the charged-particle material: type, unit, range, meaning.
#include <palpate/charged_def.h>

namespace palpate {

std::span<const Param<ChargedMaterialDef>> param_table(const ChargedMaterialDef*) {
  using D = ChargedMaterialDef;
  static const Param<D> table[] = {
      {"max_displacement", &D::max_displacement, 1e-6, 1.0, "m",
       "farthest a particle may move from its origin (rigidity)"},
      {"elasticity", &D::elasticity, 0.0, 1e4, "1/s",
       "rate at which a released particle returns to its origin; 0 = stays where pushed"},
      {"sphere_of_influence", &D::sphere_of_influence, 1e-6, 1.0, "m",
       "HIP radius + particle radius: range of the repulsion; scales the object"},
      {"max_separation", &D::max_separation, 1e-6, 1.0, "m",
       "largest distance allowed between a particle and each neighbour"},
      {"particle_charge", &D::particle_charge, 1e-15, 1.0, "C", "charge of each particle"},
      {"hip_charge", &D::hip_charge, 1e-15, 1.0, "C",
       "charge of the haptic interaction point, same sign as the particles"},
      {"puncture_force", &D::puncture_force, 0.0, 100.0, "N",
       "force at maximum displacement beyond which the patch is punctured"},
      {"hole_closes", &D::hole_closes, 0, 1, "", "whether a puncture hole closes after the tool leaves"},
      {"track_friction", &D::track_friction, 0.0, 100.0, "N",
       "kinetic friction of a punctured layer on the tool moving along its track (both ways)"},
      {"friction_velocity", &D::friction_velocity, 1e-6, 10.0, "m/s",
       "axial speed over which track friction rises from 0 to its kinetic value (tanh)"},
      {"mesh_spacing", &D::mesh_spacing, 1e-6, 1.0, "m",
       "target particle spacing when the patch is laid on a mesh (isotropic remeshing)"},
  };
  return table;
}

}  // namespace palpate
