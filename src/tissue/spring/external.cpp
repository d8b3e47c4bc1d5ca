// external.cpp — the external forces of a step: gravity, the tool's probe (an explicit penalty on the
// vertices inside it) and its grasp (springs to the grasped vertices, faded out when let go).
#include <palpate/spring.h>

#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>

namespace palpate::spring {

namespace {

Vec3 gravity_vector(const SpringModelOptions& o) {
  return o.gravity ? Vec3(0, -o.gravity_acceleration, 0) : Vec3::Zero();
}

// Forces from the tool, added to f (n x 3), and their reaction on the tool.
// Probe: a penalty on every vertex inside the sphere (tip, radius), f = k_c (r − |x − tip|) n̂ minus a
// normal damper, k_c clamped to max_contact_stiffness so the explicit penalty stays stable.
// Grasp: vertices within radius + grasp_radius when the grasp starts follow the tool on springs; let
// go, the springs fade out over grasp_release_time (a grasped organ's pull does not vanish in a tick).
Vec3 add_tool_forces(const SpringModel& model, SpringState& s, const ToolState& tool, RowMat3d& f) noexcept {
  const SpringModelOptions& o = model.options;
  const Eigen::Index n = s.x.rows();
  Vec3 on_tool = Vec3::Zero();
  s.contacts = 0;
  const double r = std::max(tool.radius, 0.0);
  if (tool.grasp && !s.grasping) {
    // Grab the nearest vertices within reach (at most kMaxGrasped), nearest first.
    s.grasped_count = 0;
    const double reach = r + o.grasp_radius;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (model.anchored[static_cast<size_t>(i)]) continue;
      const double d = (s.x.row(i).transpose() - tool.tip).norm();
      if (d > reach) continue;
      int slot = s.grasped_count;
      if (slot == SpringState::kMaxGrasped) {
        // Replace the farthest if this one is nearer.
        int far = 0;
        double far_d = -1;
        for (int k = 0; k < slot; ++k) {
          const double dk = (s.x.row(s.grasped[static_cast<size_t>(k)]).transpose() - tool.tip).norm();
          if (dk > far_d) { far_d = dk; far = k; }
        }
        if (far_d <= d) continue;
        slot = far;
      } else {
        ++s.grasped_count;
      }
      s.grasped[static_cast<size_t>(slot)] = static_cast<int>(i);
      s.grasp_offset[static_cast<size_t>(slot)] = s.x.row(i).transpose() - tool.tip;
    }
    s.grasping = true;
    s.grasp_hold = 1;
  } else if (!tool.grasp && s.grasped_count > 0) {
    s.grasping = false;
    s.grasp_hold = o.grasp_release_time > 0 ? s.grasp_hold - step_length(o) / o.grasp_release_time : 0.0;
    if (!(s.grasp_hold > 0)) {
      s.grasp_hold = 0;
      s.grasped_count = 0;
    }
  } else if (!tool.grasp) {
    s.grasping = false;
  }
  // Faded by smoothstep of the time left (no kink in the force where the release starts or ends).
  const double hold = s.grasp_hold * s.grasp_hold * (3.0 - 2.0 * s.grasp_hold);
  for (int k = 0; k < s.grasped_count; ++k) {
    const int i = s.grasped[static_cast<size_t>(k)];
    const double kg = hold * std::min(o.grasp_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const Vec3 target = tool.tip + s.grasp_offset[static_cast<size_t>(k)];
    const Vec3 fi = kg * (target - s.x.row(i).transpose());
    f.row(i) += fi.transpose();
    on_tool -= fi;
  }
  if (o.contact == SpringContact::surface) {
    // The contact force the last step ended with acts through this one (surface_contact corrects it
    // after the solve).
    s.carried_on_tool.setZero();
    for (int k = 0; k < s.contact_vertex_count; ++k) {
      const int i = s.contact_vertex[static_cast<size_t>(k)];
      f.row(i) += s.contact_load[static_cast<size_t>(k)].transpose();
      s.carried_on_tool -= s.contact_load[static_cast<size_t>(k)];
    }
    return on_tool + s.carried_on_tool;
  }
  if (r <= 0 || o.contact_stiffness <= 0) return on_tool;
  const double r2 = r * r;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 d = s.x.row(i).transpose() - tool.tip;
    const double d2 = d.squaredNorm();
    if (d2 >= r2 || model.anchored[static_cast<size_t>(i)]) continue;
    const double dist = std::sqrt(d2);
    const Vec3 normal = dist > 1e-12 * r ? Vec3(d / dist) : Vec3(-tool.axis.normalized());
    const double kc = std::min(o.contact_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const double approach = (s.v.row(i).transpose() - tool.velocity).dot(normal);
    const double magnitude = std::max(0.0, kc * (r - dist) - o.contact_damping * approach);
    const Vec3 fi = magnitude * normal;
    f.row(i) += fi.transpose();
    on_tool -= fi;
    ++s.contacts;
  }
  return on_tool;
}

}  // namespace

// External and point-damping-free forces: gravity, then the tool. Returns the force on the tool.
Vec3 external_forces(const SpringModel& model, SpringState& s, const ToolState* tool, RowMat3d& f) noexcept {
  const Vec3 g = gravity_vector(model.options);
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) f.row(i) = (model.network.mass[static_cast<size_t>(i)] * g).transpose();
  return tool ? add_tool_forces(model, s, *tool, f) : Vec3::Zero();
}

}  // namespace palpate::spring
