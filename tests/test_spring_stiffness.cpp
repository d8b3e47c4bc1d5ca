// test_spring_stiffness.cpp — the E → springs mapping (Van Gelder's rule, with the volume term of
// poisson_ratio) gives the same block the same stiffness on two different tet meshes of it: a
// structured grid and a Gmsh fill of the same boundary, hanging under its weight and indented by a
// sphere past half its radius.
#include <palpate/mesh.h>
#include <palpate/spring.h>
#include <palpate/meshing.h>

#include "components.h"
#include "spring_fixtures.h"
#include "sanitized.h"
#include "tissue/spring/shapes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {
using namespace palpate;

SurfaceMesh boundary_of(const TetMesh& t) {
  SurfaceMesh s;
  s.V = t.V;
  const auto tris = spring::boundary_triangles(t);
  s.F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t k = 0; k < tris.size(); ++k)
    for (int c = 0; c < 3; ++c) s.F(static_cast<Eigen::Index>(k), c) = tris[k][static_cast<size_t>(c)];
  return s;
}

// Hanging under its own weight from its top face: mean downward displacement of the bottom face.
double hanging_sag(const TetMesh& mesh, double nu) {
  const double bottom = mesh.V.col(1).minCoeff();
  SpringModelOptions mo;
  mo.solver = SpringSolver::sparse;
  mo.point_damping = 0.01;
  const SpringModel model =
      spring_test::must_build(spring_test::tissue_network(mesh, nu, 1060, 0.02, spring_test::Held::top), mo);
  SpringState s = make_state(model);
  for (int k = 0; k < 1500; ++k) step(model, s, nullptr);
  double sum = 0;
  int count = 0;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (mesh.V(i, 1) < bottom + 1e-9) { sum += mesh.V(i, 1) - s.x(i, 1); ++count; }
  return sum / count;
}
}  // namespace

// A 2 cm cube (5³ grid vertices, 5 mm apart; the Gmsh fill of its boundary: 113 vertices) of 5 kPa
// tissue hung from its top face: the bottom's mean sag is the same on both meshes within 10 %
// (measured ν = 0.45: 0.257 / 0.270 mm, 4.9 %; ν = 0.48: 1.0 %). Not the 1-D bar's ρgL²/2E
// (0.42 mm): a cube held by its whole top face is far from a bar.
TEST(SpringStiffness, HangingBlockSagsTheSameOnTwoMeshes) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const TetMesh grid = spring::make_block(5, 5, 5, 0.005);
  auto gmsh = tetrahedralize(boundary_of(grid), 0.005);
  ASSERT_TRUE(gmsh.ok()) << gmsh.error().message;
  for (double nu : {0.45, 0.48}) {
    const double a = hanging_sag(grid, nu), b = hanging_sag(*gmsh, nu);
    std::printf("hanging, nu %.2f: grid %.4f mm, gmsh %.4f mm\n", nu, a * 1e3, b * 1e3);
    EXPECT_GT(a, 0);
    EXPECT_NEAR(b / a, 1.0, 0.10) << "nu " << nu;
  }
}

namespace {
// A sphere of radius R pressed into the middle of the top face at 10 mm/s to depth dmax and held:
// force (on the tool, up) at each requested depth (quasi-static: speed slow against the block).
// `tissue_depth` (optional) gets the depth of the tissue's own indentation at each: d minus the
// contact's penalty depth F/k_c (the contact in series with the tissue).
// `settle` ticks at each depth; `point_damping` (N·s/m per vertex) only changes how fast it settles.
std::vector<double> indent(const TetMesh& mesh, double nu, double R, const std::vector<double>& depths,
                           std::vector<double>* tissue_depth = nullptr, int settle = 300, double point_damping = 0.01) {
  const double top = mesh.V.col(1).maxCoeff();
  const double cx = 0.5 * (mesh.V.col(0).maxCoeff() + mesh.V.col(0).minCoeff());
  const double cz = 0.5 * (mesh.V.col(2).maxCoeff() + mesh.V.col(2).minCoeff());
  auto net = spring_test::tissue_network(mesh, nu, 1060, 0.02, spring_test::Held::bottom);
  SpringModelOptions mo;
  mo.solver = SpringSolver::sparse;
  mo.gravity = false;
  mo.point_damping = point_damping;
  mo.contact_stiffness = 1000;  // a device's; the tissue's depth is d minus the contact's
  const SpringModel model = spring_test::must_build(std::move(net), mo);
  SpringState s = make_state(model);
  ToolState tool;
  tool.radius = R;
  std::vector<double> out;
  for (double d : depths) {
    for (int k = 0; k < settle; ++k) {  // move to depth d and settle
      tool.tip = Vec3(cx, top + R - d, cz);
      step(model, s, &tool);
    }
    out.push_back(s.tool_force.y());
    if (tissue_depth) tissue_depth->push_back(d - s.contact_depth);
  }
  return out;
}
}  // namespace

// A 4 cm cube (11³ grid vertices, 4 mm apart, bottom held; and the Gmsh fill of its boundary) of
// 5 kPa, ν = 0.45 tissue, indented in the middle of its top by a sphere of radius 8 mm to 0.5–5 mm
// (past half its radius), contact stiffness 1 kN/m: the same force on both meshes within 10 % at
// every depth (measured 0.3–8.6 %). The force–depth exponent is recorded, not asserted: 1.30–1.37
// between 0.5 and 1 mm, not Hertz's 1.5 — at that depth the contact is a few vertices of a 4 mm
// mesh, and the block is finite (docs/models/mass-spring.md).
TEST(SpringStiffness, SphereIndentationGivesTheSameForceOnTwoMeshes) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const TetMesh grid = spring::make_block(11, 11, 11, 0.004);
  auto gmsh = tetrahedralize(boundary_of(grid), 0.004);
  ASSERT_TRUE(gmsh.ok()) << gmsh.error().message;
  const double R = 0.008, nu = 0.45;
  const std::vector<double> d = {0.0005, 0.001, 0.002, 0.003, 0.004, 0.005};
  const auto a = indent(grid, nu, R, d), b = indent(*gmsh, nu, R, d);
  for (size_t k = 0; k < d.size(); ++k) {
    std::printf("indent %.1f mm: grid %.4f N, gmsh %.4f N, Hertz (half-space) %.4f N\n", d[k] * 1e3, a[k], b[k],
                4.0 / 3.0 * 5000 / (1 - nu * nu) * std::sqrt(R) * std::pow(d[k], 1.5));
    EXPECT_GT(a[k], 0);
    EXPECT_NEAR(b[k] / a[k], 1.0, 0.10) << "depth " << d[k];
    if (k > 0) {
      EXPECT_GT(a[k], a[k - 1]);
    }
  }
  const double ea = std::log(a[1] / a[0]) / std::log(2.0), eb = std::log(b[1] / b[0]) / std::log(2.0);
  std::printf("force-depth exponent 0.5-1 mm: grid %.3f, gmsh %.3f\n", ea, eb);
  RecordProperty("exponent_grid", std::to_string(ea));
  RecordProperty("exponent_gmsh", std::to_string(eb));
}

// Experiment, not a check (issue 21): the force–depth exponent at small depth against the mesh
// spacing (4, 2, 1.33 mm), from the tool's travel and from the tissue's own depth. It swings between
// 1.20 and 1.42 and does not settle to Hertz's 1.5 at these depths (figures and the reason:
// docs/models/mass-spring.md, "Why the exponent is low"). Run with --gtest_also_run_disabled_tests
// (about 95 s).
TEST(SpringStiffness, DISABLED_IndentationExponentAgainstTheMeshSpacing) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  const double R = 0.008, nu = 0.45;
  const std::vector<double> d = {0.00025, 0.0005, 0.001, 0.002};
  for (int n : {11, 21, 31}) {
    const double spacing = 0.04 / (n - 1);
    const TetMesh grid = spring::make_block(n, n, n, spacing);
    std::vector<double> td;
    const auto f = indent(grid, nu, R, d, &td);
    for (size_t k = 1; k < d.size(); ++k)
      std::printf("spacing %.2f mm, %.2f-%.2f mm: F %.5f-%.5f N, exponent %.3f, tissue depth %.4f-%.4f mm: %.3f\n",
                  spacing * 1e3, d[k - 1] * 1e3, d[k] * 1e3, f[k - 1], f[k], std::log(f[k] / f[k - 1]) / std::log(d[k] / d[k - 1]),
                  td[k - 1] * 1e3, td[k] * 1e3, std::log(f[k] / f[k - 1]) / std::log(td[k] / td[k - 1]));
  }
}

namespace {
// Least-squares slope of log y against log x.
double log_log_slope(const std::vector<double>& x, const std::vector<double>& y) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = static_cast<double>(x.size());
  for (size_t k = 0; k < x.size(); ++k) {
    const double lx = std::log(x[k]), ly = std::log(y[k]);
    sx += lx; sy += ly; sxx += lx * lx; sxy += lx * ly;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace

// Hertz at small depth (issue 21): a 4 cm wide, 4 cm deep block (bottom held) of 5 kPa, ν = 0.45
// tissue, meshed finely (0.5 mm) under an 8 mm sphere and coarsely (4 mm) away — a structured grid
// graded toward the contact point, and Gmsh's fill of its boundary graded the same way (fill
// refinement) — indented at eight depths from 0.3 to 1.2 mm (Hertz's contact radius √(Rd) 1.5 to
// 3.1 mm: 3 to 6 fine spacings). The least-squares exponent of the force against the tissue's own
// depth (the tool's travel minus the contact's F/k_c) is Hertz's 1.5 within 5 % on both meshes.
TEST(SpringStiffness, SmallDepthIndentationFollowsHertzsExponentOnGradedMeshes) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  // Numerics on 21,780- and 7,754-vertex meshes settled 2,400 times: past 300 s under a sanitizer;
  // the Gmsh fill it uses is run under the sanitizers by MeshTetrahedralize.*.
  if (kSanitized) GTEST_SKIP() << "run by the release suite (sanitized.h)";
  const double R = 0.008, nu = 0.45, E = 5000;
  const double fine = 0.0005, coarse = 0.004, ratio = 1.3;        // m; cells grow by 30 % away from the fine region
  const double half = 0.02, height = 0.04;                        // the block: 4 × 4 cm, 4 cm deep
  const double fine_half = 0.004, fine_depth = 0.003;             // the fine region: 8 × 8 mm, 3 mm deep
  const double d0 = 0.0003, d1 = 0.0012;
  const auto xs = spring::graded_coordinates(-half, half, -fine_half, fine_half, fine, coarse, ratio);
  const auto ys = spring::graded_coordinates(-height, 0, -fine_depth, 0, fine, coarse, ratio);
  const TetMesh grid = spring::make_block(xs, ys, xs);
  FillOptions fill;
  fill.max_edge = coarse;
  fill.refine.push_back(FillRefinement{.center = Vec3::Zero(), .radius = fine_half, .size = fine, .growth = 0.3});
  auto gmsh = tetrahedralize(boundary_of(grid), fill);
  ASSERT_TRUE(gmsh.ok()) << gmsh.error().message;
  std::printf("graded grid: %ld vertices (%zu x %zu x %zu lines); Gmsh fill: %ld vertices\n",
              static_cast<long>(grid.V.rows()), xs.size(), ys.size(), xs.size(), static_cast<long>(gmsh->V.rows()));
  std::vector<double> d;
  const int count = 8;
  for (int k = 0; k < count; ++k) d.push_back(d0 * std::pow(d1 / d0, k / double(count - 1)));
  const double estar = E / (1 - nu * nu);
  const TetMesh* filled = &*gmsh;
  for (const TetMesh* mesh : {&grid, filled}) {
    const char* name = mesh == &grid ? "grid" : "gmsh";
    // Point damping only sets how fast it settles (not where): the 11³ block's total (13 N·s/m),
    // shared by this mesh's vertices.
    std::vector<double> td;
    const auto f = indent(*mesh, nu, R, d, &td, 300, 13.0 / static_cast<double>(mesh->V.rows()));
    for (size_t k = 0; k < d.size(); ++k) {
      const double hertz = 4.0 / 3.0 * estar * std::sqrt(R) * std::pow(td[k], 1.5);
      std::printf("%s: travel %.3f mm, tissue %.4f mm: F %.5f N, Hertz %.5f N (x%.3f)\n", name, d[k] * 1e3,
                  td[k] * 1e3, f[k], hertz, f[k] / hertz);
      // Hertz's half-space force, a little stiffer: a 4 cm layer bonded to a held base (Dimitriadis
      // et al. 2002's correction for a/h = 0.04–0.08 is 1.05–1.10).
      EXPECT_GT(f[k] / hertz, 0.95) << name << " depth " << d[k];
      EXPECT_LT(f[k] / hertz, 1.25) << name << " depth " << d[k];
    }
    const double raw = log_log_slope(d, f), tissue = log_log_slope(td, f);
    std::printf("%s: exponent (least squares, %.1f-%.1f mm) against the travel %.3f, against the tissue's depth %.3f\n",
                name, d0 * 1e3, d1 * 1e3, raw, tissue);
    RecordProperty(std::string("exponent_") + name, std::to_string(tissue));
    EXPECT_NEAR(tissue, 1.5, 0.075) << name;
  }
}
