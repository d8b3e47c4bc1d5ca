// palpate/spring_def.h — parameters of the mass-spring-damper organ model (scene-file material).
#pragma once

#include <palpate/params.h>

namespace palpate {

// Material of one mass-spring-damper organ (DESIGN.md §2). SI units.
struct SpringMaterialDef {
  std::string topology = "edges";  // all_pairs | edges | tet_edges
  std::string solver = "desbrun";  // desbrun | sparse | exact
  double stiffness = 100.0;        // N/m per spring; ignored when youngs_modulus > 0
  double youngs_modulus = 0.0;     // Pa; > 0 derives each spring's stiffness from it
  double poisson_ratio = 0.0;      // > 0: a volume term on tetrahedra, in [0.25, 0.5); needs youngs_modulus
  double spring_damping = 0.1;     // N·s/m along each spring
  double point_damping = 0.5;      // N·s/m, the paper's −γẋ on each mass
  double mass = 0.1;               // kg, total; ignored when density > 0
  double density = 0.0;            // kg/m³; > 0 lumps mass from volume
  bool gravity = true;             // 9.8 m/s² along −y
  double gravity_acceleration = 9.8;  // m/s², magnitude of gravity along −y
  bool angular_momentum_correction = true;  // the predictor's post-step correction (DS99)
  std::string contact = "surface";   // surface | vertices
  double contact_stiffness = 500.0;  // N/m: the contact's penalty (surface: per metre of depth)
  double grasp_radius = 0.002;       // m beyond the tool's radius that grasping reaches
  double grasp_stiffness = 200.0;    // N/m per grasped vertex
  double grasp_release_time = 0.05;  // s over which a let-go grasp lets go (the jaws opening)
  double cutting_force = 1.0;      // N, contact force at which a blade starts to cut (docs/models/cutting.md)
  double cutting_drag_per_length = 170.0;  // N/m, drag per metre of edge in the organ while cutting
  std::string predictor = "";      // predictor file; "" = next to the output
  std::string predictor_policy = "load_or_compute";  // load_or_compute | require_file
  bool single_precision = false;   // per-tick predictor (and uniform all-pairs forces) in float
  int exact_iterations = 0;        // conjugate-gradient steps toward exact backward Euler per tick
  std::string integrator = "backward_euler";  // backward_euler | bdf2
  bool directional_correction = false;  // the right-hand side's −hKv with each spring's exact stiffness
  double fill_max_edge = 0.0;      // m; a surface filled with tetrahedra (tet_edges): their largest size, 0 = as the surface's edges
  double fill_refine_size = 0.0;   // m; > 0: the fill is graded, this size within fill_refine_radius of fill_refine_center
  Vec3 fill_refine_center = Vec3::Zero();  // m, in the scene's frame (after the mesh's scale and translate)
  double fill_refine_radius = 0.0;  // m
  double fill_refine_growth = 0.3;  // m of size per m of distance beyond fill_refine_radius
  double physics_rate = 0.0;       // Hz; > 0: the organ steps on its own thread at this rate (its
                                   // predictor built for 1/physics_rate s), the haptic thread solving
                                   // the contact against its compliance every tick (docs/haptics.md)
};

std::span<const Param<SpringMaterialDef>> param_table(const SpringMaterialDef*);

}  // namespace palpate
