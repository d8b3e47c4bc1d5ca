// params.cpp — the scene keys of the mass-spring-damper material: type, unit, range, meaning.
#include <palpate/spring_def.h>

namespace palpate {

std::span<const Param<SpringMaterialDef>> param_table(const SpringMaterialDef*) {
  using D = SpringMaterialDef;
  static const Param<D> table[] = {
      {"topology", &D::topology, 0, 0, "", "which vertex pairs get a spring", "all_pairs|edges|tet_edges"},
      {"solver", &D::solver, 0, 0, "", "implicit integrator", "desbrun|sparse|exact"},
      {"stiffness", &D::stiffness, 0.0, 1e9, "N/m", "stiffness of each spring"},
      {"youngs_modulus", &D::youngs_modulus, 0.0, 1e10, "Pa",
       "when > 0, each spring's stiffness is derived from it (docs/models/mass-spring.md)"},
      {"poisson_ratio", &D::poisson_ratio, 0.0, 0.499, "",
       "when > 0 (0.25 to 0.499, tetrahedra and youngs_modulus): springs carry the shear modulus and a "
       "per-tetrahedron volume term the rest of the bulk modulus, which also resists inversion"},
      {"spring_damping", &D::spring_damping, 0.0, 1e6, "N·s/m", "damping along each spring"},
      {"point_damping", &D::point_damping, 0.0, 1e6, "N·s/m", "the paper's −γẋ on every mass"},
      {"mass", &D::mass, 1e-9, 1e6, "kg", "total mass, shared by the vertices"},
      {"density", &D::density, 0.0, 1e5, "kg/m³", "when > 0, vertex masses are lumped from volume"},
      {"gravity", &D::gravity, 0, 1, "", "whether gravity acts (along −y)"},
      {"gravity_acceleration", &D::gravity_acceleration, 0.0, 100.0, "m/s²", "magnitude of gravity"},
      {"angular_momentum_correction", &D::angular_momentum_correction, 0, 1, "",
       "the predictor's post-step correction that keeps a free body's angular momentum"},
      {"contact", &D::contact, 0, 0, "",
       "the tool against the surface triangles (a penalty made implicit, any vertex mass), or the first "
       "model's explicit penalty on each vertex inside it (clamped)", "surface|vertices"},
      {"contact_stiffness", &D::contact_stiffness, 0.0, 1e7, "N/m",
       "surface: the contact's stiffness, force per metre of the tool's depth into the surface; vertices: per "
       "vertex inside the probe (clamped for stability)"},
      {"grasp_radius", &D::grasp_radius, 0.0, 1.0, "m", "reach of grasping beyond the tool's radius"},
      {"grasp_stiffness", &D::grasp_stiffness, 0.0, 1e7, "N/m", "stiffness tying each grasped vertex to the tool"},
      {"grasp_release_time", &D::grasp_release_time, 0.0, 1.0, "s",
       "a let-go grasp's springs fade to zero over this time (the jaws opening), not at once"},
      {"cutting_force", &D::cutting_force, 1e-6, 100.0, "N",
       "contact force at which a blade pressed on the organ starts to cut it (docs/models/cutting.md)"},
      {"cutting_drag_per_length", &D::cutting_drag_per_length, 0.0, 1e5, "N/m",
       "drag on a cutting blade per metre of its edge inside the organ"},
      {"predictor", &D::predictor, 0, 0, "", "predictor file (written by `palpate precompute` or the first run); empty: the predictor cache's (`--cache`; ~/.cache/palpate/predictors), never beside the scene"},
      {"predictor_policy", &D::predictor_policy, 0, 0, "",
       "on a missing or mismatched predictor file: recompute it, or stop", "load_or_compute|require_file"},
      {"single_precision", &D::single_precision, 0, 1, "",
       "keep the per-tick predictor (and uniform all-pairs forces) in float: faster, Δv to ~1e-6 relative"},
      {"exact_iterations", &D::exact_iterations, 0, 20, "",
       "after the predictor, this many conjugate-gradient steps on the exact backward-Euler system (the "
       "predictor as preconditioner): backward Euler's damping of transverse motion, one solve more each"},
      {"integrator", &D::integrator, 0, 0, "",
       "how a step advances: backward Euler (first order, the paper's), or BDF2 (second order, L-stable: the same "
       "one-factor predictor built for 2/3 of the step, from an extrapolated state; closer to the 1 ms truth at a "
       "long physics period)", "backward_euler|bdf2"},
      {"directional_correction", &D::directional_correction, 0, 1, "",
       "the predictor's right-hand side with each spring's exact (directional) stiffness: close to backward "
       "Euler's damping of transverse motion with no extra solve (tet and edge networks; not with "
       "exact_iterations)"},
      {"fill_max_edge", &D::fill_max_edge, 0.0, 10.0, "m",
       "a surface mesh filled with tetrahedra (topology tet_edges): the tetrahedra's largest size, 0 = as the "
       "surface's edges"},
      {"fill_refine_size", &D::fill_refine_size, 0.0, 10.0, "m",
       "when > 0, the fill is graded: tetrahedra of about this size within fill_refine_radius of "
       "fill_refine_center, growing by fill_refine_growth per metre beyond (e.g. fine under an indenter, "
       "coarse away); the surface's own triangles are kept"},
      {"fill_refine_center", &D::fill_refine_center, -1e6, 1e6, "m",
       "centre of the finely filled region, in the scene's frame (after the mesh's scale and translate)"},
      {"fill_refine_radius", &D::fill_refine_radius, 0.0, 10.0, "m", "radius of the finely filled region"},
      {"fill_refine_growth", &D::fill_refine_growth, 1e-3, 10.0, "",
       "size gained per metre of distance beyond fill_refine_radius (m/m)"},
      {"physics_rate", &D::physics_rate, 0.0, 1000.0, "Hz",
       "when > 0, the organ steps on its own thread at this rate (an organ too large for 1 ms) and the haptic "
       "thread solves the contact against its compliance every tick; `palpate run --physics-rate` overrides it"},
  };
  return table;
}

}  // namespace palpate
