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
  SpringNetworkOptions no;
  no.topology = SpringTopology::tet_edges;
  no.youngs_modulus = 5000;
  no.poisson_ratio = poisson;
  no.density = density;
  no.spring_damping = 0.01;
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) no.anchors.push_back(i + nx * (ny * k));
  auto net = make_spring_network(spring::make_block(nx, ny, nz, spacing), no, "block");
  EXPECT_TRUE(net.ok()) << net.error().message;
  SpringModelOptions mo;
  mo.solver = SpringSolver::sparse;
  mo.gravity = false;
  mo.point_damping = 0.001;
  mo.contact = contact;
  mo.contact_stiffness = contact_stiffness;
  return spring_test::must_build(std::move(*net), mo);
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
