// external.cpp — the external forces of a step: gravity, the tool's probe (an explicit penalty on the
// vertices inside it) and its grasp (springs to the grasped vertices, faded out when let go), and a
// second tool's in the other hand (a grasper).
#include <palpate/spring.h>

#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>

namespace palpate::spring {

namespace {

Vec3 gravity_vector(const SpringModelOptions& o) {
  return o.gravity ? Vec3(0, -o.gravity_acceleration, 0) : Vec3::Zero();
}

// A tool's grasp: vertices within radius + grasp_radius when the grasp starts follow the tool on
// springs; let go, the springs fade out over grasp_release_time (a grasped organ's pull does not
// vanish in a tick). Adds to f, returns the reaction on the tool.
Vec3 add_grasp_forces(const SpringModel& model, const SpringState& s, SpringGrasp& g, const ToolState& tool,
                      RowMat3d& f) noexcept {
  const SpringModelOptions& o = model.options;
  const Eigen::Index n = s.x.rows();
  const double r = std::max(tool.radius, 0.0);
  if (tool.grasp && !g.grasping) {
    // Grab the nearest vertices within reach (at most kMaxGrasped), nearest first.
    g.count = 0;
    const double reach = r + o.grasp_radius;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (model.anchored[static_cast<size_t>(i)]) continue;
      const double d = (s.x.row(i).transpose() - tool.tip).norm();
      if (d > reach) continue;
      int slot = g.count;
      if (slot == SpringGrasp::kMaxGrasped) {
        // Replace the farthest if this one is nearer.
        int far = 0;
        double far_d = -1;
        for (int k = 0; k < slot; ++k) {
          const double dk = (s.x.row(g.grasped[static_cast<size_t>(k)]).transpose() - tool.tip).norm();
          if (dk > far_d) { far_d = dk; far = k; }
        }
        if (far_d <= d) continue;
        slot = far;
      } else {
        ++g.count;
      }
      g.grasped[static_cast<size_t>(slot)] = static_cast<int>(i);
      g.offset[static_cast<size_t>(slot)] = s.x.row(i).transpose() - tool.tip;
    }
    g.grasping = true;
    g.hold = 1;
  } else if (!tool.grasp && g.count > 0) {
    g.grasping = false;
    g.hold = o.grasp_release_time > 0 ? g.hold - step_length(o) / o.grasp_release_time : 0.0;
    if (!(g.hold > 0)) {
      g.hold = 0;
      g.count = 0;
    }
  } else if (!tool.grasp) {
    g.grasping = false;
  }
  // Faded by smoothstep of the time left (no kink in the force where the release starts or ends).
  const double hold = g.hold * g.hold * (3.0 - 2.0 * g.hold);
  Vec3 on_tool = Vec3::Zero();
  for (int k = 0; k < g.count; ++k) {
    const int i = g.grasped[static_cast<size_t>(k)];
    const double kg = hold * std::min(o.grasp_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const Vec3 target = tool.tip + g.offset[static_cast<size_t>(k)];
    const Vec3 fi = kg * (target - s.x.row(i).transpose());
    f.row(i) += fi.transpose();
    on_tool -= fi;
  }
  return on_tool;
}

// A probe's explicit penalty on every vertex inside the sphere (tip, radius), f = k_c (r − |x − tip|) n̂
// minus a normal damper, k_c clamped to max_contact_stiffness so it stays stable. Adds to f, counts
// the vertices in `contacts`, returns the reaction on the tool.
Vec3 add_penalty_forces(const SpringModel& model, const SpringState& s, const ToolState& tool, RowMat3d& f,
                        int& contacts) noexcept {
  const SpringModelOptions& o = model.options;
  const double r = std::max(tool.radius, 0.0);
  Vec3 on_tool = Vec3::Zero();
  if (r <= 0 || o.contact_stiffness <= 0) return on_tool;
  const double r2 = r * r;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
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
    ++contacts;
  }
  return on_tool;
}

// Forces from the tool, added to f (n x 3), and their reaction on the tool: its grasp, then its
// contact (the surface contact's carried load, or the penalty).
Vec3 add_tool_forces(const SpringModel& model, SpringState& s, const ToolState& tool, RowMat3d& f) noexcept {
  s.contacts = 0;
  Vec3 on_tool = add_grasp_forces(model, s, s.grasp, tool, f);
  if (model.options.contact == SpringContact::surface) {
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
  return on_tool + add_penalty_forces(model, s, tool, f, s.contacts);
}

}  // namespace

// External and point-damping-free forces: gravity, then the tool. Returns the force on the tool.
Vec3 external_forces(const SpringModel& model, SpringState& s, const ToolState* tool, RowMat3d& f) noexcept {
  const Vec3 g = gravity_vector(model.options);
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) f.row(i) = (model.network.mass[static_cast<size_t>(i)] * g).transpose();
  if (s.has_second_tool) {
    // The other hand's tool: its grasp and its penalty (the surface contact follows one tool only).
    int touching = 0;
    s.second_tool_force = add_grasp_forces(model, s, s.second_grasp, s.second_tool, f) +
                          add_penalty_forces(model, s, s.second_tool, f, touching);
  } else {
    s.second_tool_force.setZero();
  }
  return tool ? add_tool_forces(model, s, *tool, f) : Vec3::Zero();
}

}  // namespace palpate::spring
