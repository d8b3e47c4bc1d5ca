// test_charged_model.cpp — charged-particle patches: lattice indexing, bent shapes, build errors, memory.
#include <palpate/charged.h>

#include <gtest/gtest.h>

#include <cmath>
#include <set>

using namespace palpate;

namespace {

PatchDef flat_patch(double w, double h, double spacing) {
  PatchDef p;
  p.width = w, p.height = h, p.spacing = spacing;
  return p;
}

}  // namespace

TEST(ChargedModel, LatticeIsRowMajorHexagonalWithSixNeighbours) {
  auto m = build_charged_patch(flat_patch(0.02, 0.01, 0.001), ChargedMaterialDef{});
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->cols, 21);
  EXPECT_EQ(m->rows, 12);  // 0.01 / (0.001·√3/2) = 11.5 → 11 gaps
  ASSERT_EQ(m->size(), size_t(21 * 12));
  // Particle r*cols+c: u grows with c, v with r; odd rows shifted by spacing/2.
  for (int r = 0; r < m->rows; ++r)
    for (int c = 0; c + 1 < m->cols; ++c) {
      const int i = r * m->cols + c;
      EXPECT_NEAR((m->origin(size_t(i) + 1) - m->origin(size_t(i))).dot(m->tangent_u), 0.001, 1e-9);
      if (r + 1 < m->rows) {
        const Vec3 d = m->origin(size_t(i + m->cols)) - m->origin(size_t(i));
        EXPECT_NEAR(d.dot(m->tangent_v), 0.001 * std::sqrt(3.0) / 2, 1e-9);
        EXPECT_NEAR(d.dot(m->tangent_u), (r % 2 == 0) ? 0.0005 : -0.0005, 1e-9);
      }
    }
  // Neighbours: at most six, symmetric, all at the rest spacing; interior particles have six.
  std::array<int, 6> nb{}, back{};
  int interior = 0;
  for (int i = 0; i < int(m->size()); ++i) {
    const int k = m->neighbours_of(i, nb);
    ASSERT_LE(k, 6);
    const int r = i / m->cols, c = i % m->cols;
    if (r > 0 && r + 1 < m->rows && c > 0 && c + 1 < m->cols) {
      EXPECT_EQ(k, 6) << "particle " << i;
      ++interior;
    }
    for (int a = 0; a < k; ++a) {
      EXPECT_NEAR((m->origin(size_t(nb[size_t(a)])) - m->origin(size_t(i))).norm(), 0.001, 1e-8);
      const int kb = m->neighbours_of(nb[size_t(a)], back);
      EXPECT_NE(std::find(back.begin(), back.begin() + kb, i), back.begin() + kb);
    }
  }
  EXPECT_EQ(interior, 10 * 19);
  // Every rest normal is the patch normal.
  for (size_t i = 0; i < m->size(); ++i) EXPECT_NEAR(m->particle_normal(i).dot(Vec3::UnitY()), 1.0, 1e-4);
}

TEST(ChargedModel, BentPatchesLieOnTheirCylinderAndSphere) {
  PatchDef p = flat_patch(0.05, 0.03, 0.001);
  p.radius = 0.02;
  p.center = Vec3(0.01, 0.02, -0.03);
  p.normal = Vec3(0, 0, 1);
  for (const char* shape : {"cylinder", "sphere"}) {
    p.shape = shape;
    auto m = build_charged_patch(p, ChargedMaterialDef{});
    ASSERT_TRUE(m.ok()) << m.error().message;
    const Vec3 axis_point = p.center - p.radius * Vec3(0, 0, 1);
    for (size_t i = 0; i < m->size(); ++i) {
      Vec3 d = m->origin(i) - axis_point;
      if (std::string(shape) == "cylinder") d -= d.dot(m->tangent_v) * m->tangent_v;
      EXPECT_NEAR(d.norm(), p.radius, 1e-8) << shape << " particle " << i;
      EXPECT_NEAR(m->particle_normal(i).dot(d.normalized()), 1.0, 1e-4) << shape << " particle " << i;
    }
    // Bending shortens neighbour distances (chord ≤ arc), never lengthens them.
    std::array<int, 6> nb{};
    for (int i = 0; i < int(m->size()); ++i)
      for (int a = 0, k = m->neighbours_of(i, nb); a < k; ++a)
        EXPECT_LE((m->origin(size_t(nb[size_t(a)])) - m->origin(size_t(i))).norm(), 0.001 + 1e-8);
  }
}

TEST(ChargedModel, BuildErrorsNameTheKeyAndWhatWasExpected) {
  ChargedMaterialDef mat;
  auto bad_shape = build_charged_patch([] { PatchDef p; p.shape = "torus"; return p; }(), mat, "s.yaml:4: tissue 'skin'");
  ASSERT_FALSE(bad_shape.ok());
  EXPECT_EQ(bad_shape.error().message, "s.yaml:4: tissue 'skin': patch 'shape' is 'torus'; expected flat, cylinder or sphere");
  auto bad_spacing = build_charged_patch(flat_patch(0.04, 0.04, 0.0), mat, "w");
  ASSERT_FALSE(bad_spacing.ok());
  EXPECT_EQ(bad_spacing.error().message, "w: patch 'spacing' is 0 m; expected a finite value > 0");
  mat.max_separation = 0.001;
  auto tight = build_charged_patch(flat_patch(0.04, 0.04, 0.001), mat, "w");
  ASSERT_FALSE(tight.ok());
  EXPECT_EQ(tight.error().message,
            "w: material 'max_separation' (0.001 m) must exceed the rest distance between neighbours "
            "(0.001 m), or the patch would violate the separation rule at rest");
  mat = ChargedMaterialDef{};
  mat.friction_presliding = std::nan("");
  auto nan_z0 = build_charged_patch(flat_patch(0.04, 0.04, 0.001), mat, "w");
  ASSERT_FALSE(nan_z0.ok());
  EXPECT_EQ(nan_z0.error().message, "w: material 'friction_presliding' is nan m; expected a finite value > 0");
  mat = ChargedMaterialDef{};
  mat.linear_share = 1.5;
  auto share = build_charged_patch(flat_patch(0.04, 0.04, 0.001), mat, "w");
  ASSERT_FALSE(share.ok());
  EXPECT_EQ(share.error().message, "w: material 'linear_share' is 1.5; expected a value in [0, 1]");
  // Without max_separation the limit follows the spacing: the same strain at any resolution.
  for (double spacing : {0.0005, 0.001, 0.002}) {
    auto ok = build_charged_patch(flat_patch(0.04, 0.04, spacing), ChargedMaterialDef{}, "w");
    ASSERT_TRUE(ok.ok());
    EXPECT_DOUBLE_EQ(ok->max_separation, (1 + ChargedMaterialDef{}.max_strain) * spacing);
  }
  PatchDef wrap = flat_patch(0.2, 0.01, 0.001);
  wrap.shape = "cylinder", wrap.radius = 0.02;
  auto too_wide = build_charged_patch(wrap, ChargedMaterialDef{}, "w");
  ASSERT_FALSE(too_wide.ok());
  EXPECT_NE(too_wide.error().message.find("patch 'width' (0.2 m) must be less than the cylinder's circumference"),
            std::string::npos)
      << too_wide.error().message;
}

TEST(ChargedModel, MemoryPerParticleWithinBudgetAndStateAtRest) {
  auto m = build_charged_patch(flat_patch(0.04, 0.04, 0.001), ChargedMaterialDef{});
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(charged_bytes_per_particle(*m), 40u);  // float origin+position, snorm16 normal, flags, 2 scratch indices, cut mask
  ChargedModel mesh_like = *m;
  mesh_like.layout = ChargedLayout::mesh;
  EXPECT_EQ(charged_bytes_per_particle(mesh_like), 64u);  // + 6 explicit int32 neighbours
  ChargedState s = make_charged_state(*m);
  ASSERT_EQ(s.x.size(), m->size());
  EXPECT_EQ(s.active.size(), m->size());
  EXPECT_EQ(s.queue.size(), m->size());
  for (size_t i = 0; i < m->size(); ++i) EXPECT_EQ(s.position(i), m->origin(i));
  EXPECT_EQ(s.active_count, 0u);
}
