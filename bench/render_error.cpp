// render_error.cpp — the scripted probing of an organ, synchronous and multi-rate, and the force
// error between them (issue 24).
#include "render_error.h"

#include "tissue/spring/shapes.h"

#include <algorithm>
#include <cmath>
#include <memory>

namespace palpate {

SpringNetwork tet_ball_organ(double radius_in_spacings) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = 100.0;
  o.mass = 0.5;
  SpringNetwork net = *make_spring_network(spring::make_tet_ball(radius_in_spacings * 0.002, 0.002), o, "organ");
  const double lo = net.rest.col(1).minCoeff(), hi = net.rest.col(1).maxCoeff();
  for (Eigen::Index i = 0; i < net.rest.rows(); ++i)
    if (net.rest(i, 1) < lo + 0.05 * (hi - lo)) net.anchors.push_back(static_cast<int>(i));
  return net;
}

ProbeScript probe_script(const SpringNetwork& net) {
  ProbeScript s;
  s.top = Vec3(net.rest.col(0).mean(), net.rest.col(1).maxCoeff(), net.rest.col(2).mean());
  return s;
}

namespace {
// Smoothstep on [0, 1] and its derivative.
double smooth(double u) { u = std::clamp(u, 0.0, 1.0); return u * u * (3 - 2 * u); }
double smooth_rate(double u) { return u <= 0 || u >= 1 ? 0.0 : 6 * u * (1 - u); }
}  // namespace

ToolState ProbeScript::at(long tick) const {
  const double t = static_cast<double>(tick) * dt;
  const double y0 = top.y() + radius + 0.001, travel = 0.001 + depth;
  const double press = smooth(t / leg) - smooth((t - 2 * leg) / leg);
  const double press_rate = (smooth_rate(t / leg) - smooth_rate((t - 2 * leg) / leg)) / leg;
  const double along = smooth((t - leg) / leg), along_rate = smooth_rate((t - leg) / leg) / leg;
  ToolState tool;
  tool.time = t;
  tool.radius = radius;
  tool.tip = Vec3(top.x() + slide * along, y0 - travel * press, top.z());
  tool.velocity = Vec3(slide * along_rate, -travel * press_rate, 0);
  return tool;
}

std::vector<Vec3> synchronous_forces(const SpringModel& model, const ProbeScript& script) {
  SpringState s = make_state(model);
  std::vector<Vec3> f(static_cast<size_t>(script.ticks()));
  for (long k = 0; k < script.ticks(); ++k) {
    const ToolState tool = script.at(k);
    f[static_cast<size_t>(k)] = step(model, s, &tool) ? s.tool_force : Vec3::Zero();
  }
  return f;
}

RenderError multirate_error(SpringModel model, MultiRateContact method, const ProbeScript& script,
                            const std::vector<Vec3>& truth, double max_stiffness, bool with_step_reference) {
  const double physics_dt = step_length(model.options);  // one physics step's time (BDF2: 1.5 h)
  // The step reference: the same model stepped in lockstep with the worker's (same tools, same
  // ticks, so the same states), and from each of its states once more every tick on a copy.
  std::unique_ptr<SpringModel> ref;
  SpringState ref_state, prev_state, trial;
  if (with_step_reference) {
    ref = std::make_unique<SpringModel>(model);
    ref_state = make_state(*ref);
    prev_state = trial = ref_state;
  }
  const long every = std::max(1L, std::lround(physics_dt / script.dt));
  double step_sum2 = 0, step_max = 0;
  auto tissue = make_spring_tissue("organ", std::move(model));
  PhysicsWorker worker(*tissue, 0, physics_dt, script.dt, max_stiffness, false, method);
  worker.start();
  RenderError e;
  const long n = std::min<long>(script.ticks(), static_cast<long>(truth.size()));
  e.force.resize(static_cast<size_t>(n));
  std::vector<double> figures(tissue->figure_names().size());
  double sum2 = 0, max_err = 0;
  for (long k = 0; k < n; ++k) {
    Vec3 f = Vec3::Zero();
    (void)worker.render(script.at(k), 0, 0.0, f, figures);
    e.force[static_cast<size_t>(k)] = f;
    const double err = (f - truth[static_cast<size_t>(k)]).norm();
    sum2 += err * err;
    max_err = std::max(max_err, err);
    e.peak = std::max(e.peak, truth[static_cast<size_t>(k)].norm());
    if (ref) {
      const ToolState tool = script.at(k);
      if (k % every == 0) {  // the worker's physics step, taken the same way: keep the state before it
        prev_state = ref_state;
        (void)step(*ref, ref_state, &tool);
      }
      trial = prev_state;  // that step again, from the same state, with this tick's tool
      const Vec3 f_ref = step(*ref, trial, &tool) ? trial.tool_force : Vec3::Zero();
      const double d = (f - f_ref).norm();
      step_sum2 += d * d;
      step_max = std::max(step_max, d);
    }
  }
  worker.stop();
  if (e.peak > 0 && n > 0) {
    e.rms = std::sqrt(sum2 / static_cast<double>(n)) / e.peak;
    e.max = max_err / e.peak;
    e.step_rms = std::sqrt(step_sum2 / static_cast<double>(n)) / e.peak;
    e.step_max = step_max / e.peak;
  }
  e.patch_ticks = worker.patch_ticks();
  e.patch_fallbacks = worker.patch_fallbacks();
  e.physics_steps = worker.physics_steps();
  return e;
}

}  // namespace palpate
