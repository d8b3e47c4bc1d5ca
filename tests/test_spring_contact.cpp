// test_spring_contact.cpp — the mass-spring model's surface contact (SpringContact::surface): the
// tool against the surface triangles, implicit whatever the vertex masses, carried from tick to tick.
// A probe smaller than the mesh spacing presses a face between vertices and does not slip; the force
// rises on every tick of a steady press; at rest it is k_c times the depth and does not depend on the
// masses; a stiff contact on light vertices stays stable; a tool that starts inside is pushed out.
#include <palpate/spring.h>

#include "spring_fixtures.h"
#include "tissue/spring/shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace {

using namespace palpate;

// A block of 5 kPa tissue, nx x ny x nz vertices `spacing` apart, bottom layer anchored, ν = 0.45.
SpringModel tissue_block(int nx, int ny, int nz, double spacing, double density, SpringContact contact,
                         double contact_stiffness = 500.0, double poisson = 0.45) {
  auto net = spring_test::tissue_network(spring::make_block(nx, ny, nz, spacing), poisson, density, 0.01,
                                         spring_test::Held::bottom);
  SpringModelOptions mo;
  mo.solver = SpringSolver::sparse;
  mo.gravity = false;
  mo.point_damping = 0.001;
  mo.contact = contact;
  mo.contact_stiffness = contact_stiffness;
  return spring_test::must_build(std::move(net), mo);
}

struct Press {
  std::vector<double> force;  // N, |tool force| per tick while pressing
  double settled_force = 0;   // N after the hold
  double settled_depth = 0;   // m, the tool's sphere into the surface after the hold
  std::uint64_t resets = 0;
  double min_force_y = 0;     // N, the most negative vertical force on the tool (pulling down)
};

// A sphere of radius r comes down on (x, z) from `start` above the top surface at `speed`, presses to
// `depth` below the rest surface, then holds for `hold` s.
Press press(const SpringModel& model, double top, double x, double z, double r, double depth, double speed,
            double hold, double start = 0.001) {
  SpringState s = make_state(model);
  ToolState tool;
  tool.radius = r;
  Press out;
  const double h = model.options.dt;
  const double y0 = top + r + start, y1 = top + r - depth;
  const int moving = static_cast<int>(std::ceil((y0 - y1) / (speed * h)));
  const int holding = static_cast<int>(std::lround(hold / h));
  for (int k = 0; k < moving + holding; ++k) {
    tool.time = (k + 1) * h;
    tool.tip = Vec3(x, std::max(y1, y0 - speed * h * (k + 1)), z);
    tool.velocity = Vec3(0, k < moving ? -speed : 0.0, 0);
    EXPECT_TRUE(step(model, s, &tool));
    if (k < moving) out.force.push_back(s.tool_force.norm());
    out.min_force_y = std::min(out.min_force_y, s.tool_force.y());
  }
  out.settled_force = s.tool_force.norm();
  out.settled_depth = s.contact_depth;
  out.resets = s.resets;
  return out;
}

// From the first tick with force on: the largest fall from one tick to the next, relative.
double largest_fall(const std::vector<double>& f) {
  double worst = 0;
  size_t k = 0;
  while (k < f.size() && !(f[k] > 0)) ++k;
  for (++k; k < f.size(); ++k) worst = std::max(worst, (f[k - 1] - f[k]) / f[k - 1]);
  return worst;
}

}  // namespace

// A 1 mm probe on a block meshed 5 mm apart, over the middle of a face (no vertex under it),
// pressed 2 mm at 5 mm/s: the triangles carry it. The force rises on every tick (no fall above
// 1 %) and ends well above zero; with the first, per-vertex contact the probe slips between the
// vertices and feels (almost) nothing.
TEST(SpringContactSurface, SmallProbeOnACoarseMeshPressesTheFaceAndTheForceRises) {
  const double spacing = 0.005, top = 4 * spacing;
  const SpringModel model = tissue_block(6, 5, 6, spacing, 1060, SpringContact::surface);
  const Press p = press(model, top, 2.4 * spacing, 2.3 * spacing, 0.001, 0.002, 0.005, 0.2);
  const SpringModel old = tissue_block(6, 5, 6, spacing, 1060, SpringContact::vertices);
  const Press q = press(old, top, 2.4 * spacing, 2.3 * spacing, 0.001, 0.002, 0.005, 0.2);
  std::printf("small probe: surface peak %.4f N settled %.4f N fall %.4f; vertices peak %.5f N\n",
              *std::max_element(p.force.begin(), p.force.end()), p.settled_force, largest_fall(p.force),
              *std::max_element(q.force.begin(), q.force.end()));
  EXPECT_EQ(p.resets, 0u);
  EXPECT_LT(largest_fall(p.force), 0.01);
  EXPECT_GT(p.settled_force, 0.05);
  EXPECT_LT(*std::max_element(q.force.begin(), q.force.end()), 0.1 * p.settled_force);
}

// At rest the contact force is the penalty k_c · depth, and it does not depend on the vertex
// masses: the same press on the same block at tissue density and at 100 times it settles to the
// same force (a static equilibrium). k_c = 1000 N/m on vertices of 0.1 g (h² k_c / m ≈ 10, where
// the explicit penalty needed its clamp) stays stable.
TEST(SpringContactSurface, SettledForceIsStiffnessTimesDepthWhateverTheMasses) {
  const double spacing = 0.005, top = 4 * spacing;
  const SpringModel light = tissue_block(6, 5, 6, spacing, 1060, SpringContact::surface, 1000.0);
  const SpringModel heavy = tissue_block(6, 5, 6, spacing, 106000, SpringContact::surface, 1000.0);
  const Press a = press(light, top, 2.5 * spacing, 2.5 * spacing, 0.004, 0.003, 0.005, 1.0);
  const Press b = press(heavy, top, 2.5 * spacing, 2.5 * spacing, 0.004, 0.003, 0.005, 3.0);
  std::printf("k*depth: light %.4f N depth %.3f mm; heavy %.4f N depth %.3f mm\n", a.settled_force,
              a.settled_depth * 1e3, b.settled_force, b.settled_depth * 1e3);
  EXPECT_EQ(a.resets + b.resets, 0u);
  EXPECT_NEAR(a.settled_force, 1000.0 * a.settled_depth, 0.01 * a.settled_force);
  EXPECT_NEAR(a.settled_force, b.settled_force, 0.02 * a.settled_force);
  EXPECT_GT(a.settled_force, 0.05);
}

// Stiff contact on light vertices: 1 mm spacing, tissue density (vertex masses ≈ 1 mg), k_c = 1 kN/m,
// h² k_c / m ≈ 1000: no reset, a finite force that settles, never pulling the tool in.
TEST(SpringContactSurface, StiffContactOnLightVerticesIsStable) {
  const double spacing = 0.001, top = 6 * spacing;
  const SpringModel model = tissue_block(9, 7, 9, spacing, 1060, SpringContact::surface, 1000.0);
  const Press p = press(model, top, 4.3 * spacing, 4.4 * spacing, 0.0015, 0.0015, 0.01, 0.3);
  std::printf("stiff light: settled %.4f N, fall %.4f, min fy %.4f\n", p.settled_force, largest_fall(p.force),
              p.min_force_y);
  EXPECT_EQ(p.resets, 0u);
  EXPECT_GT(p.settled_force, 0.0);
  EXPECT_LT(p.settled_force, 10.0);
  EXPECT_GE(p.min_force_y, 0.0);
  EXPECT_LT(largest_fall(p.force), 0.01);
}

// A tool that starts 3 mm inside the organ (under its top face, centre below the surface) is pushed
// out: the force on it points up, out of the organ, on every tick, and the tissue yields (a dimple
// forms, so the depth and the force fall to what the tissue's stiffness holds).
TEST(SpringContactSurface, ToolStartingInsideIsPushedOut) {
  const double spacing = 0.005, top = 4 * spacing;
  const SpringModel model = tissue_block(6, 5, 6, spacing, 1060, SpringContact::surface);
  SpringState s = make_state(model);
  ToolState tool;
  tool.radius = 0.002;
  tool.tip = Vec3(2.5 * spacing, top - 0.003, 2.4 * spacing);
  double first_depth = 0;
  for (int k = 0; k < 50; ++k) {
    ASSERT_TRUE(step(model, s, &tool));
    if (k == 0) first_depth = s.contact_depth;
    EXPECT_GT(s.tool_force.y(), 0.0) << "tick " << k;
    EXPECT_GT(s.tool_force.y(), 0.7 * s.tool_force.norm()) << "tick " << k;  // out, mostly through the top face
  }
  EXPECT_GT(first_depth, 0.002 + 0.003 - 1e-4);  // the depth is the radius plus the centre's 3 mm
  EXPECT_LT(s.contact_depth, first_depth);
}

// No tunnelling: a 1 mm probe driven fast (0.1 m/s, a tenth of a millimetre per tick) 8 mm into a
// block meshed 1 cm apart, between its vertices, deeper than its own diameter: once it touches, the
// force never drops to zero and points out of the organ on every tick; it ends well above zero.
TEST(SpringContactSurface, FastSmallProbeDoesNotTunnelThroughACoarseMesh) {
  const double spacing = 0.01, top = 3 * spacing;
  const SpringModel model = tissue_block(5, 4, 5, spacing, 1060, SpringContact::surface);
  const Press p = press(model, top, 1.6 * spacing, 1.3 * spacing, 0.001, 0.008, 0.1, 0.1);
  size_t first = 0;
  while (first < p.force.size() && !(p.force[first] > 0)) ++first;
  ASSERT_LT(first, p.force.size());
  size_t zero_after = 0;
  for (size_t k = first; k < p.force.size(); ++k)
    if (!(p.force[k] > 0)) ++zero_after;
  std::printf("fast probe: touched at tick %zu of %zu, settled %.4f N, largest fall %.4f, min fy %.4f\n", first,
              p.force.size(), p.settled_force, largest_fall(p.force), p.min_force_y);
  EXPECT_EQ(zero_after, 0u);
  EXPECT_GE(p.min_force_y, 0.0);
  EXPECT_GT(p.settled_force, 0.05);
  EXPECT_EQ(p.resets, 0u);
}

// ---- A needle's shaft against the surface triangles (ToolState::needle with a length). ----

namespace {

struct ShaftRun {
  std::vector<Vec3> force;   // N on the tool, per tick while moving
  Vec3 settled = Vec3::Zero();
  SpringState state;
};

// The tool moves from `from` to `to` (its tip) at `speed`, then holds for `hold` s.
ShaftRun drive(const SpringModel& model, ToolState tool, const Vec3& from, const Vec3& to, double speed, double hold) {
  ShaftRun out{{}, Vec3::Zero(), make_state(model)};
  const double h = model.options.dt;
  const double travel = (to - from).norm();
  const int moving = static_cast<int>(std::ceil(travel / (speed * h)));
  const int holding = static_cast<int>(std::lround(hold / h));
  const Vec3 dir = (to - from) / travel;
  for (int k = 0; k < moving + holding; ++k) {
    tool.time = (k + 1) * h;
    tool.tip = from + std::min(travel, speed * h * (k + 1)) * dir;
    tool.velocity = k < moving ? Vec3(speed * dir) : Vec3::Zero();
    EXPECT_TRUE(step(model, out.state, &tool));
    if (k < moving) out.force.push_back(out.state.tool_force);
  }
  out.settled = out.state.tool_force;
  return out;
}

ToolState needle(double radius, double length, const Vec3& axis) {
  ToolState t;
  t.radius = radius;
  t.needle = true;
  t.length = length;
  t.axis = axis;
  return t;
}

}  // namespace

// A needle (r = 0.5 mm) laid sideways along x over the top of a 4 x 1.5 x 2 cm block (5 mm mesh),
// its 24 mm shaft centred on the block's middle, pressed 1.5 mm down and held. The faces under the
// whole shaft carry it: the load on the surface is spread along its length (each end quarter takes
// more than a tenth of it) and symmetric about its middle (within 3 %); the force is up, with
// nothing along the shaft;
// the top vertices under its ends are pushed down like the one under its middle; and the line is
// stiffer than its tip alone (a sphere of the same radius at the tip, the same path: more than twice
// the force).
TEST(SpringContactShaft, NeedleLaidSidewaysPressesTheSurfaceAlongItsLength) {
  const double spacing = 0.005, top = 3 * spacing, r = 0.0005, length = 0.024, z = 2.3 * spacing;
  const SpringModel model = tissue_block(9, 4, 5, spacing, 1060, SpringContact::surface);
  const ToolState lying = needle(r, length, Vec3(1, 0, 0));
  const double xmid = 4 * spacing, xtip = xmid + length / 2;
  const Vec3 from(xtip, top + r + 0.001, z), to(xtip, top + r - 0.0015, z);
  const ShaftRun run = drive(model, lying, from, to, 0.005, 0.3);
  ToolState ball;
  ball.radius = r;
  const ShaftRun tip = drive(model, ball, from, to, 0.005, 0.3);
  const SpringState& s = run.state;
  double left = 0, right = 0, low_end = 0, high_end = 0, total = 0;
  for (int k = 0; k < s.contact_vertex_count; ++k) {
    const int i = s.contact_vertex[static_cast<size_t>(k)];
    const double load = s.contact_load[static_cast<size_t>(k)].norm(), x = model.network.rest(i, 0);
    total += load;
    if (x < xmid - 1e-9) left += load;
    else if (x > xmid + 1e-9) right += load;
    else left += load / 2, right += load / 2;
    if (x < xmid - length / 4) low_end += load;
    if (x > xmid + length / 4) high_end += load;
  }
  // The top vertices nearest the shaft (row z = 2 spacings) under its ends and its middle.
  auto sag = [&](int i) { return model.network.rest(i + 9 * (3 + 4 * 2), 1) - s.x(i + 9 * (3 + 4 * 2), 1); };
  std::printf("shaft: force %.4f N (tip alone %.4f N), %d vertices, left %.4f right %.4f, ends %.3f %.3f of "
              "%.4f; sag at x = 10, 20, 30 mm: %.3f %.3f %.3f mm\n",
              run.settled.norm(), tip.settled.norm(), s.contact_vertex_count, left, right, low_end, high_end, total,
              sag(2) * 1e3, sag(4) * 1e3, sag(6) * 1e3);
  EXPECT_EQ(s.resets, 0u);
  EXPECT_GT(run.settled.y(), 0.99 * run.settled.norm());  // up (a little z: the shaft lies off the middle in z)
  EXPECT_LT(std::abs(run.settled.x()), 0.001 * run.settled.norm());  // nothing along the shaft: symmetric
  EXPECT_NEAR(left, right, 0.03 * total);
  EXPECT_GT(low_end, 0.1 * total);
  EXPECT_GT(high_end, 0.1 * total);
  EXPECT_GT(sag(2), 0.5 * sag(4));
  EXPECT_GT(sag(6), 0.5 * sag(4));
  EXPECT_NEAR(sag(2), sag(6), 0.05 * sag(4));
  EXPECT_GT(run.settled.norm(), 2 * tip.settled.norm());
}

// No tunnelling: a thin needle (r = 0.4 mm) laid sideways, its 2 cm shaft between the vertex rows of
// a block meshed 1 cm apart (no vertex under it), driven 8 mm down fast (0.1 m/s, a quarter of its
// radius per tick). Once it touches, the force never drops to zero and points out of the organ on
// every tick, though the penalty's depth grows past the needle's radius (the shaft then presses
// the faces it is behind); it ends well above zero, mostly upward, with the surface carried down
// under it. (Measured: 0.51 N, 85 % of it upward; the 1 cm faces tilt, and the load ends on the
// vertex nearest the shaft's tip end, which slides under it: a coarse mesh, deeper than its faces
// can follow.)
TEST(SpringContactShaft, NeedleSweptDownOnACoarseMeshDoesNotTunnel) {
  const double spacing = 0.01, top = 3 * spacing, r = 0.0004, length = 0.02, z = 1.3 * spacing;
  const SpringModel model = tissue_block(5, 4, 5, spacing, 1060, SpringContact::surface);
  const ToolState lying = needle(r, length, Vec3(1, 0, 0));
  const double xtip = 2 * spacing + length / 2;
  const ShaftRun run = drive(model, lying, Vec3(xtip, top + r + 0.001, z), Vec3(xtip, top + r - 0.008, z), 0.1, 0.1);
  size_t first = 0;
  while (first < run.force.size() && !(run.force[first].norm() > 0)) ++first;
  ASSERT_LT(first, run.force.size());
  size_t zero_after = 0;
  double min_fy = 0;
  for (size_t k = first; k < run.force.size(); ++k) {
    if (!(run.force[k].norm() > 0)) ++zero_after;
    min_fy = std::min(min_fy, run.force[k].y());
  }
  double sag = 0;  // the deepest top vertex: the surface carried down with the shaft
  for (Eigen::Index i = 0; i < run.state.x.rows(); ++i)
    if (model.network.rest(i, 1) > top - 1e-9) sag = std::max(sag, model.network.rest(i, 1) - run.state.x(i, 1));
  std::printf("swept shaft: touched at tick %zu of %zu, settled %.4f N (up %.4f), depth %.3f mm, deepest top vertex "
              "%.2f mm down, %d contact vertices\n",
              first, run.force.size(), run.settled.norm(), run.settled.y(), run.state.contact_depth * 1e3, sag * 1e3,
              run.state.contact_vertex_count);
  EXPECT_EQ(zero_after, 0u);
  EXPECT_GE(min_fy, 0.0);
  EXPECT_GT(run.settled.norm(), 0.05);
  EXPECT_GT(run.settled.y(), 0.8 * run.settled.norm());  // mostly out of the organ (the mesh is coarse)
  EXPECT_GT(sag, 0.005);  // the shaft went 7.6 mm below the rest surface, carrying it
  EXPECT_EQ(run.state.resets, 0u);
}

// A needle pressed tip first (its shaft straight up, out of the organ) 0.3 mm into a face, less than
// its radius: the shaft touches nothing its tip does not, so every tick's force is the tip sphere's
// (a sphere tool of the same radius on the same path) to round-off.
TEST(SpringContactShaft, TipFirstNeedleFeelsWhatItsTipSphereFeels) {
  const double spacing = 0.005, top = 4 * spacing, r = 0.0005;
  const SpringModel model = tissue_block(6, 5, 6, spacing, 1060, SpringContact::surface);
  const Vec3 from(2.4 * spacing, top + r + 0.001, 2.3 * spacing), to(2.4 * spacing, top + r - 0.0003, 2.3 * spacing);
  const ShaftRun a = drive(model, needle(r, 0.03, Vec3(0, -1, 0)), from, to, 0.005, 0.1);
  ToolState ball;
  ball.radius = r;
  const ShaftRun b = drive(model, ball, from, to, 0.005, 0.1);
  ASSERT_EQ(a.force.size(), b.force.size());
  double worst = 0;
  for (size_t k = 0; k < a.force.size(); ++k) worst = std::max(worst, (a.force[k] - b.force[k]).norm());
  std::printf("tip first: settled %.5f N (sphere %.5f N), largest difference %.2e N\n", a.settled.norm(),
              b.settled.norm(), worst);
  EXPECT_GT(b.settled.norm(), 0.01);
  EXPECT_LT(worst, 1e-9 * b.settled.norm());
  EXPECT_LT((a.settled - b.settled).norm(), 1e-9 * b.settled.norm());
}
