// test_contact_compliance.cpp — issue 24: the exact compliance of a mass-spring organ's vertices
// (SpringCompliance), the haptic thread's contact solve against it (solve_patch), and the
// multi-rate force against the synchronous truth on the 11k organ.
#include <palpate/haptics.h>
#include <palpate/scene.h>
#include <palpate/spring.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "haptics/patch_contact.h"
#include "render_error.h"
#include "sanitized.h"
#include "spring_fixtures.h"
#include "tissue/spring/solve.h"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

using namespace palpate;
using spring_test::block_network;
using spring_test::must_build;

namespace {

SpringModelOptions options(SpringSolver solver, double dt) {
  SpringModelOptions o;
  o.solver = solver;
  o.dt = dt;
  return o;
}

// The model at a physics rate as the multi-rate path builds it (data/scenes/large-organ.yaml, the
// benchmark): directional_correction on, the step's contact against the exact diagonal of A⁻¹.
SpringModel physics_rate_model(const SpringNetwork& net, double dt) {
  SpringModelOptions o = options(SpringSolver::sparse, dt);
  o.directional_correction = true;
  SpringModel m = must_build(net, o);
  EXPECT_TRUE(use_exact_contact_compliance(m));
  return m;
}

// h² (A⁻¹)_ij from full solves with the model's factor: column j is A⁻¹ e_j.
double reference_w(const SpringModel& model, int i, int j) {
  const Eigen::Index n = static_cast<Eigen::Index>(model.network.size());
  RowMat3d b = RowMat3d::Zero(n, 3), x(n, 3), scratch(n, 3);
  b(j, 0) = 1.0;
  spring::solve_columns(model.predictor, b, x, scratch);
  return model.options.dt * model.options.dt * x(i, 0);
}

}  // namespace

TEST(SpringCompliance, BlockIsTheStepsOwnCompliance) {
  // W from the half-solves along elimination-tree paths equals h² A⁻¹ from full solves, to
  // round-off, for vertices near and far apart; anchored vertices do not move (W = 0); symmetric.
  const SpringModel model = must_build(block_network(7, 7, 7, 0.005, 100.0, 0.2, true), options(SpringSolver::sparse, 0.02));
  SpringCompliance c(model, 16);
  ASSERT_TRUE(c.available());
  const std::vector<int> v = {300, 301, 342, 10, 200, 48, 0, 150, 151, 152, 99};  // 0 and 10 are anchored
  std::vector<double> w(v.size() * v.size());
  c.block(v, w);
  double scale = 0;
  for (size_t a = 0; a < v.size(); ++a) scale = std::max(scale, std::abs(w[a * v.size() + a]));
  ASSERT_GT(scale, 0);
  for (size_t a = 0; a < v.size(); ++a)
    for (size_t b = 0; b < v.size(); ++b) {
      const bool anchored = model.anchored[size_t(v[a])] || model.anchored[size_t(v[b])];
      const double expect = anchored ? 0.0 : reference_w(model, v[a], v[b]);
      EXPECT_NEAR(w[a * v.size() + b], expect, 1e-10 * scale) << v[a] << "," << v[b];
      EXPECT_EQ(w[a * v.size() + b], w[b * v.size() + a]);
    }
  // More vertices than the cache holds: the least recently used go, and come back equal.
  EXPECT_EQ(c.cached(), 11u);
  std::vector<int> many;
  for (int i = 100; i < 140; ++i) many.push_back(i);
  std::vector<double> w2(many.size() * many.size());
  c.block(std::span<const int>(many.data(), 16), std::span<double>(w2.data(), 256));
  EXPECT_EQ(c.cached(), 16u);
  const std::uint64_t before = c.computed();
  std::vector<double> again(v.size() * v.size());
  c.block(v, again);
  EXPECT_GT(c.computed(), before);
  for (size_t k = 0; k < w.size(); ++k) EXPECT_DOUBLE_EQ(again[k], w[k]);
  // The dense predictor gives the same W.
  const SpringModel dense = must_build(block_network(7, 7, 7, 0.005, 100.0, 0.2, true), options(SpringSolver::desbrun, 0.02));
  SpringCompliance cd(dense);
  std::vector<double> wd(v.size() * v.size());
  cd.block(v, wd);
  for (size_t k = 0; k < w.size(); ++k) EXPECT_NEAR(wd[k], w[k], 1e-9 * scale);
}

TEST(SpringCompliance, ExactContactDiagonalIsTheStepsOwnAndTheForceFollowsThePress) {
  // use_exact_contact_compliance: each surface vertex's (A⁻¹)_ii from the path substitutions equals
  // a full solve's and is far below the mass bound it replaces, and the step's contact force then
  // follows the press (F close to k_c Φ) where the mass bound's lags.
  const SpringNetwork net = tet_ball_organ(8.0);
  const SpringModel bound = must_build(net, options(SpringSolver::sparse, 0.02));
  SpringModel exact = bound;
  ASSERT_TRUE(use_exact_contact_compliance(exact));
  ASSERT_TRUE(exact.contact_compliance_exact);
  const double h2 = 0.02 * 0.02;
  int checked = 0, surface = 0;
  for (size_t i = 0; i < net.size(); i += 7) {
    const bool on_surface = exact.contact_compliance[i] != bound.contact_compliance[i] || bound.anchored[i];
    if (!on_surface) continue;
    ++surface;
    const double expect = bound.anchored[i] ? 0.0 : reference_w(bound, static_cast<int>(i), static_cast<int>(i)) / h2;
    EXPECT_NEAR(exact.contact_compliance[i], expect, 1e-9 * (1 + expect)) << i;
    EXPECT_LE(exact.contact_compliance[i], bound.contact_compliance[i]) << i;
    if (!bound.anchored[i]) {
      EXPECT_LT(exact.contact_compliance[i], 0.1 * bound.contact_compliance[i]) << i;  // 0.02–0.09 measured
    }
    ++checked;
  }
  EXPECT_GT(checked, 20);
  // Pressed in over 0.5 s (25 steps of 20 ms): each step's force against the penalty it aims at,
  // F / (k_c Φ) (1 when the contact has caught up with the tool). With the mass bound the update is
  // under-relaxed about 10³ times too much and the force lags; with the exact diagonal it follows.
  const ProbeScript script = probe_script(net);
  auto lag = [&](const SpringModel& m) {
    SpringState s = make_state(m);
    double worst = 0;
    for (long k = 0; k <= 25; ++k) {
      const ToolState tool = script.at(k * 20);
      EXPECT_TRUE(step(m, s, &tool));
      if (k >= 10 && s.contact_depth > 0)  // in contact by then
        worst = std::max(worst, std::abs(1 - s.contact_force / (m.options.contact_stiffness * s.contact_depth)));
    }
    return worst;
  };
  const double lag_bound = lag(bound), lag_exact = lag(exact);
  EXPECT_LT(lag_exact, 0.5 * lag_bound) << "bound " << lag_bound << ", exact " << lag_exact;  // 0.87, 0.37 measured
}

TEST(SpringCompliance, PatchReproducesTheStepsForceAtItsOwnPose) {
  // At rest in contact (the tool held still until the force settles), the patch solved at the
  // step's own tool pose gives back the model's force: the free positions plus W times that load
  // are the positions the step ended with.
  const SpringNetwork net = tet_ball_organ(8.0);
  const SpringModel model = must_build(net, options(SpringSolver::sparse, 0.02));
  SpringState s = make_state(model);
  ProbeScript script = probe_script(net);
  ToolState tool;
  for (long k = 0; k <= 25; ++k) {  // pressed in over 0.5 s, 20 ms a step
    tool = script.at(k * 20);
    ASSERT_TRUE(step(model, s, &tool));
  }
  tool.velocity.setZero();
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(step(model, s, &tool));
  ASSERT_GT(s.tool_force.norm(), 0.03);
  SpringCompliance c(model);
  auto patch = std::make_unique<ContactPatch>();
  ASSERT_TRUE(c.contact_patch(s, tool, 0.001, *patch));
  EXPECT_GT(patch->point_count, 10);
  EXPECT_GT(patch->reach, 0.0005);
  auto scratch = std::make_unique<PatchScratch>();
  const PatchContact got = solve_patch(*patch, tool.tip, tool.radius, 1e9, *scratch);
  ASSERT_TRUE(got.valid);
  EXPECT_NEAR((got.force - s.tool_force).norm(), 0.0, 0.05 * s.tool_force.norm());  // 3.5 % measured
  // Outside its reach the patch refuses (the loop falls back to the linearised contact).
  EXPECT_FALSE(solve_patch(*patch, tool.tip + Vec3(patch->reach + 1e-4, 0, 0), tool.radius, 1e9, *scratch).valid);
}

TEST(PatchContact, RenderedStiffnessNeverExceedsTheDevices) {
  // A patch stiffer than the device (k_c = 5000 N/m, device 1000 N/m): dF/dx along the normal,
  // by finite differences over a press, stays at or below 1000 N/m; with a compliant patch it is
  // k/(1 + k w) < k.
  const SpringNetwork net = tet_ball_organ(8.0);
  SpringModelOptions o = options(SpringSolver::sparse, 0.02);
  o.contact_stiffness = 5000;
  const SpringModel model = must_build(net, o);
  SpringState s = make_state(model);
  const ProbeScript script = probe_script(net);
  ToolState tool = script.at(0);
  tool.tip = script.top + Vec3(0, script.radius - 0.0005, 0);  // 0.5 mm into the top
  SpringCompliance c(model);
  auto patch = std::make_unique<ContactPatch>();
  auto scratch = std::make_unique<PatchScratch>();
  ASSERT_TRUE(c.contact_patch(s, tool, 0.004, *patch));
  ASSERT_GT(patch->reach, 0.001);
  double prev = 0, max_k = 0;
  const double dy = 1.6 * patch->reach / 200;  // from 0.8 reach above to 0.8 reach below
  for (int k = 0; k < 200; ++k) {
    const Vec3 x = tool.tip + Vec3(0, 0.8 * patch->reach - dy * k, 0);
    const PatchContact r = solve_patch(*patch, x, tool.radius, 1000.0, *scratch);
    ASSERT_TRUE(r.valid) << k;
    if (k > 0) max_k = std::max(max_k, (r.force.y() - prev) / dy);
    prev = r.force.y();
  }
  EXPECT_GT(prev, 0.3);  // pressed about 1.5 mm
  EXPECT_LE(max_k, 1000.0 * (1 + 1e-6));
  EXPECT_GT(max_k, 100.0);
}

TEST(ContactCompliance, Organ11kAt50HzHoldsItsMeasuredError) {
  // Numerics of an 11k organ run 1,500 ticks twice (the truth and the 50 Hz rendering): 13 s in the
  // release suite, 228 s under ASan + UBSan on an idle 2-core machine and past ctest's 300 s beside
  // another build. The same code paths run under the sanitizers in the smaller ContactCompliance
  // and SpringCompliance tests and the multi-rate adversarial organ.
  if (kSanitized) GTEST_SKIP() << "run by the release suite (sanitized.h)";
  // The 11k organ probed (press, slide, release) with its physics at 50 Hz (the predictor built for
  // 20 ms, as the multi-rate path builds it: directional_correction, the step's contact against the
  // exact diagonal of A⁻¹) and the contact solved every tick against its exact compliance, against
  // the synchronous run (a 1 ms step of the default model every tick): the figure docs/BENCHMARKS.md
  // reports (2026-11-26: RMS 0.160 of the peak, max 0.474; the secant 0.170; BDF2 0.134; on
  // 2026-11-25, before the patch's points moved between steps, 0.181 and 0.600; before that, with
  // the predictor alone and the mass bound, 0.276 and 0.287). Not the 5 %
  // target: what remains is the 20 ms organ's own dynamics, not the rendering (docs/haptics.md,
  // "What the error is made of").
  const SpringNetwork net = tet_ball_organ(13.4);
  ASSERT_EQ(net.size(), 11488u);
  const ProbeScript script = probe_script(net);
  const std::vector<Vec3> truth = synchronous_forces(must_build(net, options(SpringSolver::sparse, 0.001)), script);
  const SpringModel at50 = physics_rate_model(net, 0.02);
  const RenderError compliance = multirate_error(at50, MultiRateContact::compliance, script, truth);
  const RenderError secant = multirate_error(at50, MultiRateContact::linearised, script, truth);
  EXPECT_GT(compliance.peak, 0.5);
  EXPECT_EQ(compliance.physics_steps, 75u);
  // Every tick from the patch: it holds the points within reach of the tool for a whole period (128
  // of them); with 64 the slide left its reach 37 times and fell back to the secant for a few ticks,
  // a jump of up to 0.17 N each way.
  EXPECT_EQ(compliance.patch_ticks, 1500u);
  EXPECT_LE(compliance.rms, 0.17);
  EXPECT_LE(compliance.max, 0.50);
  EXPECT_LE(secant.rms, 0.18);
  EXPECT_EQ(secant.patch_ticks, 0u);
  // Felt: no 50 Hz sawtooth in the slide. The patch's points move on with their velocity between
  // steps, so each new step lands near where the last one was heading: the largest fall from one
  // tick to the next is 0.06 of the peak (0.053 N measured; 0.174 N with the points held for the
  // period and the fallbacks), the truth's own 0.019.
  double fall = 0;
  for (size_t k = 506; k < 1000; ++k) fall = std::max(fall, compliance.force[k - 1].norm() - compliance.force[k].norm());
  EXPECT_LE(fall, 0.07 * compliance.peak);

  // BDF2 at the same period (the shipped scene's integrator): closer to the truth.
  SpringModelOptions o = options(SpringSolver::sparse, 0.02 * 2 / 3);
  o.integrator = SpringIntegrator::bdf2;
  o.directional_correction = true;
  SpringModel bdf2 = must_build(net, o);
  ASSERT_TRUE(use_exact_contact_compliance(bdf2));
  const RenderError second = multirate_error(bdf2, MultiRateContact::compliance, script, truth);
  EXPECT_EQ(second.physics_steps, 75u);
  EXPECT_LE(second.rms, 0.145);
  EXPECT_LT(second.rms, compliance.rms);
}

TEST(ContactCompliance, ClosedToolLoopPutsNoEnergyIntoTheHand) {
  // Passive: the work the rendered contact does on the hand over a closed path through the organ,
  // ∮ F·dx with the physics at 50 Hz, is not positive (a circle of 3 mm radius in the x-y plane,
  // pressing 1 to 7 mm into the top, twice round, back to the start).
  const SpringNetwork net = tet_ball_organ(8.0);
  const SpringModel model = must_build(net, options(SpringSolver::sparse, 0.02));
  const ProbeScript script = probe_script(net);
  auto tissue = make_spring_tissue("organ", model);
  PhysicsWorker worker(*tissue, 0, 0.02, 0.001, 1000.0, false, MultiRateContact::compliance);
  worker.start();
  std::vector<double> figures(tissue->figure_names().size());
  const Vec3 centre = script.top + Vec3(0, script.radius - 0.004, 0);
  const long ticks = 4000;
  double work = 0, peak = 0;
  Vec3 f_prev = Vec3::Zero(), x_prev = Vec3::Zero();
  for (long k = 0; k <= ticks; ++k) {
    const double a = 2 * std::numbers::pi * 2 * static_cast<double>(k) / ticks;  // two turns
    ToolState tool;
    tool.radius = script.radius;
    tool.tip = centre + 0.003 * Vec3(std::sin(a), std::cos(a), 0);
    tool.velocity = 0.003 * (2 * std::numbers::pi * 2 / (ticks * 0.001)) * Vec3(std::cos(a), -std::sin(a), 0);
    Vec3 f;
    (void)worker.render(tool, 0, 0.0, f, figures);
    if (k > 0) work += 0.5 * (f + f_prev).dot(tool.tip - x_prev);  // trapezoid
    f_prev = f, x_prev = tool.tip;
    peak = std::max(peak, f.norm());
  }
  EXPECT_GT(peak, 0.5);
  EXPECT_GT(worker.patch_ticks(), 3000u);
  EXPECT_LE(work, 0.0) << "peak " << peak << " N";
}

TEST(ContactCompliance, LargeOrganSceneRendersFromTheCompliance) {
  // data/scenes/large-organ.yaml as shipped, its ball shrunk to 16 mm so that the test builds in
  // seconds (every material key as the scene has it): multi-rate at its physics_rate with the
  // model's exact compliance patch (ContactComplianceSource) rendering the press — not the secant
  // fallback — and its step's contact against the exact diagonal of A⁻¹.
  auto scene = load_scene(PALPATE_SOURCE_DIR "/data/scenes/large-organ.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_EQ(scene->tissues.size(), 1u);
  TissueDef& t = scene->tissues[0];
  const double physics_dt = scene_physics_dt(t);
  EXPECT_DOUBLE_EQ(physics_dt, 0.02);
  EXPECT_TRUE(t.spring.directional_correction);
  EXPECT_EQ(t.spring.integrator, "bdf2");
  ASSERT_TRUE(t.patch.has_value());
  t.patch->radius = 0.016;
  t.patch->center = Vec3(0, -0.016, 0);  // its top at y = 0, as the scene's
  scene->output = std::filesystem::temp_directory_path() / "palpate_large_organ_test";
  auto tissue = make_tissue(*scene, 0);
  ASSERT_TRUE(tissue.ok()) << tissue.error().message;
  ASSERT_NE((*tissue)->contact_compliance(), nullptr);
  PhysicsWorker worker(**tissue, 0, physics_dt, scene->dt, scene->device.stiffness, false, MultiRateContact::compliance);
  worker.start();
  std::vector<double> figures((*tissue)->figure_names().size());
  double peak = 0;
  long touching = 0;
  for (long k = 0; k < 700; ++k) {  // the scene's press (5 mm in over 0.5 s), then held 0.2 s
    const double u = std::min(1.0, k * 0.001 / 0.5);
    ToolState tool;
    tool.time = k * 0.001;
    tool.radius = scene->tool.radius;
    tool.tip = Vec3(0, 0.005 - 0.006 * u, 0);
    tool.velocity = Vec3(0, u < 1 ? -0.012 : 0.0, 0);
    Vec3 f = Vec3::Zero();
    EXPECT_EQ(worker.render(tool, 0, 0.0, f, figures), TickFault::none);
    if (f.norm() > 0) ++touching;
    peak = std::max(peak, f.norm());
  }
  // The contact's Jacobian for the virtual coupling, from the patch's solve (not the secant):
  // symmetric, passive (eigenvalues in [−the device's stiffness, 0]), pressing back along the force.
  const Mat3 J = worker.jacobian();
  EXPECT_LT((J - J.transpose()).norm(), 1e-12 * (1 + J.norm()));
  const Eigen::Vector3d eig = Eigen::SelfAdjointEigenSolver<Mat3>(0.5 * (J + J.transpose())).eigenvalues();
  EXPECT_GE(eig.minCoeff(), -scene->device.stiffness * (1 + 1e-12));
  EXPECT_LE(eig.maxCoeff(), 1e-9);
  EXPECT_LT(eig.minCoeff(), -1.0) << "no stiffness at a 5 mm press";
  {
    // ... and it is the solve's own derivative: the patch of the organ as it stands, the force's
    // change for the tool moved 10 µm either way along the force, against −d·J·d.
    ToolState tool;
    tool.radius = scene->tool.radius;
    tool.tip = Vec3(0, -0.001, 0);
    ContactPatch patch;
    ASSERT_TRUE((*tissue)->contact_compliance()->contact_patch(tool, physics_dt, physics_dt, patch));
    PatchScratch scratch;
    const PatchContact at = solve_patch(patch, tool.tip, tool.radius, scene->device.stiffness, scratch);
    ASSERT_TRUE(at.valid);
    ASSERT_GT(at.force.norm(), 0.0);
    const Vec3 d = at.force.normalized();
    const double h = 1e-5;
    const PatchContact in = solve_patch(patch, tool.tip - h * d, tool.radius, scene->device.stiffness, scratch);
    const PatchContact out = solve_patch(patch, tool.tip + h * d, tool.radius, scene->device.stiffness, scratch);
    const double fd = (in.force.dot(d) - out.force.dot(d)) / (2 * h);
    EXPECT_NEAR(at.stiffness, fd, 0.1 * fd) << "dF/dx along the force, N/m";
  }
  worker.stop();
  std::filesystem::remove_all(scene->output);
  EXPECT_GT(peak, 0.1);
  EXPECT_GT(touching, 400);
  EXPECT_GT(worker.patch_ticks(), 600u);
  EXPECT_LE(worker.patch_fallbacks(), 20u);
}
