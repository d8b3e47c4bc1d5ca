// test_spring_momentum.cpp — the predictor's angular-momentum correction, and the forces at the
// tool: probe equilibrium against the anchors, grasping.
#include "spring_fixtures.h"

#include <cmath>

using namespace palpate;
using namespace spring_test;

namespace {

// A free block spinning about an axis through its centre of mass, no damping, no gravity.
double relative_angular_drift(SpringSolver solver, bool correction, int steps) {
  SpringModelOptions o;
  o.dt = 0.001;
  o.solver = solver;
  o.gravity = false;
  o.point_damping = 0;
  o.angular_momentum_correction = correction;
  SpringModel model = must_build(block_network(4, 4, 4, 0.01, 200.0, 0.05, false), o);
  SpringState s = make_state(model);
  const Vec3 c = model.network.rest.colwise().mean().transpose();
  const Vec3 omega(1.0, 8.0, 3.0);  // rad/s
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) s.v.row(i) = omega.cross(s.x.row(i).transpose() - c).transpose();
  const Vec3 l0 = angular_momentum(model, s);
  const Vec3 p0 = linear_momentum(model, s);
  for (int i = 0; i < steps; ++i) EXPECT_TRUE(step(model, s, nullptr));
  EXPECT_LT((linear_momentum(model, s) - p0).norm(), 1e-12);
  return (angular_momentum(model, s) - l0).norm() / l0.norm();
}

}  // namespace

TEST(SpringMomentum, CorrectionKeepsAngularMomentumOfAFreeSpinningBody) {
  for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
    const double with = relative_angular_drift(solver, true, 500);
    const double without = relative_angular_drift(solver, false, 500);
    EXPECT_LT(with, 1e-9);
    // Without the correction the predictor's transverse stiffness brakes the rotation.
    EXPECT_GT(without, 1e-3);
    EXPECT_GT(without, 1e4 * with);
  }
}

TEST(SpringContact, ProbeReactionEqualsAnchorForceAtEquilibrium) {
  for (bool gravity : {false, true}) {
    SpringModelOptions o;
    o.solver = SpringSolver::sparse;
    o.gravity = gravity;
    o.point_damping = 0.2;
    SpringModel model = must_build(block_network(5, 5, 5, 0.01, 200.0, 0.1, true, 0.05), o);
    SpringState s = make_state(model);
    ToolState tool;
    tool.radius = 0.006;
    // Held 2 mm into the top face, off-centre so the force is not purely vertical.
    tool.tip = Vec3(0.017, 0.04 + 0.006 - 0.002, 0.022);
    for (int i = 0; i < 20000; ++i) {
      ASSERT_TRUE(step(model, s, &tool));
      if (i > 100 && kinetic_energy(model, s) < 1e-18) break;
    }
    ASSERT_GT(s.contacts, 0);
    ASSERT_GT(s.tool_force.norm(), 0.01);
    EXPECT_GT(s.tool_force.y(), 0);  // the tissue pushes the tool up
    // Organ at rest: contact + anchors + weight = 0, so tool force = weight − load on the anchors.
    const Vec3 weight = gravity ? Vec3(0, -9.8 * model.total_mass, 0) : Vec3::Zero();
    const Vec3 expected = -s.anchor_force + weight;
    EXPECT_LT((s.tool_force - expected).norm(), 1e-3 * s.tool_force.norm())
        << "gravity " << gravity << " tool " << s.tool_force.transpose() << " anchors " << s.anchor_force.transpose();
  }
}

TEST(SpringContact, GraspPullsTheTissueAndItPullsBack) {
  SpringModelOptions o;
  o.solver = SpringSolver::desbrun;
  o.gravity = false;
  SpringModel model = must_build(block_network(5, 5, 5, 0.01, 200.0, 0.1, true, 0.05), o);
  SpringState s = make_state(model);
  const int top_centre = 2 + 5 * (4 + 5 * 2);
  ToolState tool;
  tool.radius = 0.001;
  tool.tip = model.network.rest.row(top_centre).transpose() + Vec3(0, 0.0015, 0);
  tool.grasp = true;
  ASSERT_TRUE(step(model, s, &tool));
  ASSERT_GE(s.grasp.count, 1);
  EXPECT_EQ(s.grasp.grasped[0], top_centre);
  for (int i = 0; i < 2000; ++i) {
    tool.tip.y() += 0.003 / 2000;  // lift by 3 mm over 2 s
    ASSERT_TRUE(step(model, s, &tool));
  }
  const double lifted = s.x(top_centre, 1) - model.network.rest(top_centre, 1);
  EXPECT_GT(lifted, 0.001);
  EXPECT_LT(s.tool_force.y(), 0);  // the tissue pulls the tool down
  tool.grasp = false;
  for (int i = 0; i < 3000; ++i) ASSERT_TRUE(step(model, s, &tool));
  EXPECT_EQ(s.grasp.count, 0);
  EXPECT_LT(s.x(top_centre, 1) - model.network.rest(top_centre, 1), 0.1 * lifted);
}
