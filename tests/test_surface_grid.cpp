// test_surface_grid.cpp — properties of the Bézier and B-spline surfaces over a control grid.
#include <palpate/surface.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

using palpate::SurfaceBuffers;
using palpate::SurfaceDef;
using palpate::SurfaceScheme;
using palpate::SurfaceTessellator;
using palpate::Vec3f;

namespace {

const SurfaceScheme kSchemes[] = {SurfaceScheme::bezier, SurfaceScheme::bspline};

const char* name(SurfaceScheme s) { return s == SurfaceScheme::bezier ? "bezier" : "bspline"; }

// A control grid with random positions in the unit cube.
std::vector<Vec3f> random_grid(int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-1.0f, 1.0f);
  std::vector<Vec3f> g(size_t(rows) * cols);
  for (auto& p : g) p = Vec3f(d(rng), d(rng), d(rng));
  return g;
}

// A grid on the plane through `origin` spanned by e1 (along columns) and e2 (along rows), with
// uneven spacing so the parameterisation is not uniform.
std::vector<Vec3f> planar_grid(int rows, int cols, const Vec3f& origin, const Vec3f& e1, const Vec3f& e2) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  std::vector<Vec3f> g(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) g[size_t(r) * cols + c] = origin + (c + jitter(rng)) * e1 + (r + jitter(rng)) * e2;
  return g;
}

Vec3f point(const SurfaceBuffers& b, size_t i) { return {b.positions[3 * i], b.positions[3 * i + 1], b.positions[3 * i + 2]}; }
Vec3f normal(const SurfaceBuffers& b, size_t i) { return {b.normals[3 * i], b.normals[3 * i + 1], b.normals[3 * i + 2]}; }

// Output index of sample (a along v, b along u) of patch (i, j).
size_t sample(const SurfaceTessellator& t, int i, int j, int a, int b) {
  const size_t r1 = size_t(t.def().resolution) + 1;
  return (size_t(i) * t.patch_cols() + j) * r1 * r1 + size_t(a) * r1 + b;
}

SurfaceTessellator make(int rows, int cols, SurfaceScheme scheme, int resolution) {
  auto t = SurfaceTessellator::build(rows, cols, SurfaceDef{scheme, resolution});
  EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
  return std::move(t).value();
}

}  // namespace

TEST(SurfaceGrid, PatchCountsFollowTheGrid) {
  // 3m+1 rows give m Bézier patches; leftovers add one partial patch; a B-spline has rows-1 spans.
  EXPECT_EQ(make(16, 31, SurfaceScheme::bezier, 4).patch_rows(), 5);
  EXPECT_EQ(make(16, 31, SurfaceScheme::bezier, 4).patch_cols(), 10);
  EXPECT_EQ(make(17, 33, SurfaceScheme::bezier, 4).patch_rows(), 6);
  EXPECT_EQ(make(17, 33, SurfaceScheme::bezier, 4).patch_cols(), 11);
  EXPECT_EQ(make(16, 31, SurfaceScheme::bspline, 4).patch_rows(), 15);
  const auto t = make(16, 31, SurfaceScheme::bezier, 19);
  EXPECT_EQ(t.point_count(), 50u * 400u);
  EXPECT_EQ(t.triangle_count(), 50u * 19u * 19u * 2u);
}

TEST(SurfaceGrid, PlanarGridGivesPlanarSurfaceWithPlaneNormal) {
  const Vec3f e1 = Vec3f(1, 0.2f, 0.1f).normalized() * 0.002f;
  const Vec3f e2raw(0.1f, 0.3f, 1.0f);
  const Vec3f e2 = (e2raw - e2raw.dot(e1.normalized()) * e1.normalized()).normalized() * 0.003f;
  const Vec3f origin(0.01f, -0.02f, 0.005f);
  const Vec3f plane_normal = e1.cross(e2).normalized();
  for (SurfaceScheme scheme : kSchemes) {
    for (auto [rows, cols] : {std::pair{7, 10}, std::pair{9, 12}, std::pair{2, 3}}) {
      const auto grid = planar_grid(rows, cols, origin, e1, e2);
      const auto t = make(rows, cols, scheme, 6);
      SurfaceBuffers out;
      ASSERT_TRUE(t.tessellate(grid, out));
      ASSERT_EQ(out.point_count(), t.point_count());
      for (size_t i = 0; i < out.point_count(); ++i) {
        EXPECT_NEAR(plane_normal.dot(point(out, i) - origin), 0.0f, 1e-7f) << name(scheme) << " point " << i;
        EXPECT_GT(normal(out, i).dot(plane_normal), 1.0f - 1e-5f) << name(scheme) << " point " << i;
      }
      // Every triangle faces the way its vertices' normals do (consistent winding).
      for (size_t f = 0; f < out.triangle_count(); ++f) {
        const auto* tri = &out.triangles[3 * f];
        const Vec3f n = (point(out, tri[1]) - point(out, tri[0])).cross(point(out, tri[2]) - point(out, tri[0]));
        EXPECT_GT(n.dot(plane_normal), 0.0f) << name(scheme) << " triangle " << f;
      }
    }
  }
}

TEST(SurfaceGrid, BezierInterpolatesTheCornerControlPointsOfEveryPatch) {
  // 11 x 12: 10 = 3·3 + 1 row segments (last patch a line), 11 = 3·3 + 2 (last a quadratic).
  const int rows = 11, cols = 12;
  const auto grid = random_grid(rows, cols, 1);
  const auto t = make(rows, cols, SurfaceScheme::bezier, 5);
  ASSERT_EQ(t.patch_rows(), 4);
  ASSERT_EQ(t.patch_cols(), 4);
  SurfaceBuffers out;
  ASSERT_TRUE(t.tessellate(grid, out));
  const int r = t.def().resolution;
  for (int i = 0; i < t.patch_rows(); ++i)
    for (int j = 0; j < t.patch_cols(); ++j) {
      const int r0 = 3 * i, r3 = std::min(3 * i + 3, rows - 1);
      const int c0 = 3 * j, c3 = std::min(3 * j + 3, cols - 1);
      EXPECT_EQ(point(out, sample(t, i, j, 0, 0)), grid[size_t(r0) * cols + c0]) << i << "," << j;
      EXPECT_EQ(point(out, sample(t, i, j, 0, r)), grid[size_t(r0) * cols + c3]) << i << "," << j;
      EXPECT_EQ(point(out, sample(t, i, j, r, 0)), grid[size_t(r3) * cols + c0]) << i << "," << j;
      EXPECT_EQ(point(out, sample(t, i, j, r, r)), grid[size_t(r3) * cols + c3]) << i << "," << j;
    }
}

TEST(SurfaceGrid, BSplineInterpolatesTheGridCorners) {
  const int rows = 6, cols = 9;
  const auto grid = random_grid(rows, cols, 2);
  const auto t = make(rows, cols, SurfaceScheme::bspline, 4);
  SurfaceBuffers out;
  ASSERT_TRUE(t.tessellate(grid, out));
  const int r = 4, pi = t.patch_rows() - 1, pj = t.patch_cols() - 1;
  EXPECT_LT((point(out, sample(t, 0, 0, 0, 0)) - grid[0]).norm(), 1e-6f);
  EXPECT_LT((point(out, sample(t, 0, pj, 0, r)) - grid[cols - 1]).norm(), 1e-6f);
  EXPECT_LT((point(out, sample(t, pi, 0, r, 0)) - grid[size_t(rows - 1) * cols]).norm(), 1e-6f);
  EXPECT_LT((point(out, sample(t, pi, pj, r, r)) - grid.back()).norm(), 1e-6f);
}

TEST(SurfaceGrid, SharedBordersHaveIdenticalPositions) {
  for (SurfaceScheme scheme : kSchemes) {
    const int rows = 11, cols = 12;
    const auto grid = random_grid(rows, cols, 3);
    const auto t = make(rows, cols, scheme, 7);
    SurfaceBuffers out;
    ASSERT_TRUE(t.tessellate(grid, out));
    const int r = t.def().resolution;
    // Bézier border points come from one-hot end weights: bitwise equal. B-spline: to rounding.
    const float tol = scheme == SurfaceScheme::bezier ? 0.0f : 1e-6f;
    for (int i = 0; i < t.patch_rows(); ++i)
      for (int j = 0; j < t.patch_cols(); ++j)
        for (int s = 0; s <= r; ++s) {
          if (j + 1 < t.patch_cols()) {  // right edge of (i,j) against left edge of (i,j+1)
            EXPECT_LE((point(out, sample(t, i, j, s, r)) - point(out, sample(t, i, j + 1, s, 0))).norm(), tol)
                << name(scheme) << " patch " << i << "," << j << " sample " << s;
          }
          if (i + 1 < t.patch_rows()) {  // top edge of (i,j) against bottom edge of (i+1,j)
            EXPECT_LE((point(out, sample(t, i, j, r, s)) - point(out, sample(t, i + 1, j, 0, s))).norm(), tol)
                << name(scheme) << " patch " << i << "," << j << " sample " << s;
          }
        }
  }
}

TEST(SurfaceGrid, BSplineIsC2AcrossKnotsAndBezierIsOnlyC0) {
  const int rows = 10, cols = 10;
  const auto grid = random_grid(rows, cols, 4);
  const auto bs = make(rows, cols, SurfaceScheme::bspline, 4);
  const float tol = 2e-5f;
  for (int i = 0; i < bs.patch_rows(); ++i)
    for (int j = 0; j + 1 < bs.patch_cols(); ++j)
      for (float v : {0.0f, 0.3f, 1.0f}) {
        const auto a = bs.evaluate(grid, i, j, 1.0f, v), b = bs.evaluate(grid, i, j + 1, 0.0f, v);
        EXPECT_LT((a.position - b.position).norm(), tol);
        EXPECT_LT((a.du - b.du).norm(), tol) << i << "," << j;
        EXPECT_LT((a.dv - b.dv).norm(), tol) << i << "," << j;
        EXPECT_LT((a.duu - b.duu).norm(), 10 * tol) << i << "," << j;
        EXPECT_LT((a.duv - b.duv).norm(), 10 * tol) << i << "," << j;
      }
  for (int i = 0; i + 1 < bs.patch_rows(); ++i)
    for (int j = 0; j < bs.patch_cols(); ++j) {
      const auto a = bs.evaluate(grid, i, j, 0.5f, 1.0f), b = bs.evaluate(grid, i + 1, j, 0.5f, 0.0f);
      EXPECT_LT((a.dv - b.dv).norm(), tol) << i << "," << j;
      EXPECT_LT((a.dvv - b.dvv).norm(), 10 * tol) << i << "," << j;
    }
  // The Bézier patches of the same random grid meet with a kink: the test above can fail.
  const auto bz = make(rows, cols, SurfaceScheme::bezier, 4);
  float worst = 0;
  for (int j = 0; j + 1 < bz.patch_cols(); ++j) {
    const auto a = bz.evaluate(grid, 0, j, 1.0f, 0.5f), b = bz.evaluate(grid, 0, j + 1, 0.0f, 0.5f);
    EXPECT_LT((a.position - b.position).norm(), 1e-6f);
    worst = std::max(worst, (a.du - b.du).norm());
  }
  EXPECT_GT(worst, 0.1f);
}

TEST(SurfaceGrid, SurfaceStaysInTheConvexHullOfItsControlPoints) {
  // A point lies in the convex hull of a set only if, along every direction, it is not beyond
  // the set's farthest point; check many directions.
  std::mt19937 rng(5);
  std::normal_distribution<float> nd;
  std::vector<Vec3f> directions(200);
  for (auto& d : directions) d = Vec3f(nd(rng), nd(rng), nd(rng)).normalized();
  for (SurfaceScheme scheme : kSchemes) {
    const int rows = 8, cols = 9;
    const auto grid = random_grid(rows, cols, 6);
    const auto t = make(rows, cols, scheme, 6);
    SurfaceBuffers out;
    ASSERT_TRUE(t.tessellate(grid, out));
    const int r = t.def().resolution;
    for (int i = 0; i < t.patch_rows(); ++i)
      for (int j = 0; j < t.patch_cols(); ++j) {
        std::vector<Vec3f> hull;
        for (int rr : t.patch_rows_of(i))
          for (int cc : t.patch_cols_of(j)) hull.push_back(grid[size_t(rr) * cols + cc]);
        for (const Vec3f& d : directions) {
          float extent = -1e30f;
          for (const Vec3f& p : hull) extent = std::max(extent, d.dot(p));
          for (int a = 0; a <= r; ++a)
            for (int b = 0; b <= r; ++b)
              ASSERT_LE(d.dot(point(out, sample(t, i, j, a, b))), extent + 1e-5f)
                  << name(scheme) << " patch " << i << "," << j << " sample " << a << "," << b;
        }
      }
  }
}

TEST(SurfaceGrid, DoublingTheResolutionGivesPointsOnTheSameSurface) {
  for (SurfaceScheme scheme : kSchemes) {
    const int rows = 8, cols = 11;
    const auto grid = random_grid(rows, cols, 8);
    const auto coarse = make(rows, cols, scheme, 5), fine = make(rows, cols, scheme, 10);
    SurfaceBuffers c, f;
    ASSERT_TRUE(coarse.tessellate(grid, c));
    ASSERT_TRUE(fine.tessellate(grid, f));
    for (int i = 0; i < coarse.patch_rows(); ++i)
      for (int j = 0; j < coarse.patch_cols(); ++j) {
        for (int a = 0; a <= 5; ++a)
          for (int b = 0; b <= 5; ++b) {
            EXPECT_LT((point(c, sample(coarse, i, j, a, b)) - point(f, sample(fine, i, j, 2 * a, 2 * b))).norm(), 1e-5f);
            EXPECT_GT(normal(c, sample(coarse, i, j, a, b)).dot(normal(f, sample(fine, i, j, 2 * a, 2 * b))), 0.9999f);
          }
        // The fine tessellation's in-between samples lie on the surface too.
        for (int a = 1; a <= 10; a += 2)
          for (int b = 1; b <= 10; b += 2) {
            const auto sp = fine.evaluate(grid, i, j, b / 10.0f, a / 10.0f);
            EXPECT_LT((sp.position - point(f, sample(fine, i, j, a, b))).norm(), 1e-5f);
            EXPECT_GT(sp.normal.dot(normal(f, sample(fine, i, j, a, b))), 0.9999f);
          }
      }
  }
}

TEST(SurfaceGrid, BSplineNormalsAreContinuousWhereBezierCreases) {
  // A dent (one control point pushed down) in a flat grid: the B-spline's normals agree across
  // span borders; the Bézier surface has a crease along the border through the dent.
  const int rows = 10, cols = 10;
  std::vector<Vec3f> grid(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) grid[size_t(r) * cols + c] = Vec3f(0.001f * c, 0, -0.001f * r);
  grid[size_t(4) * cols + 4].y() = -0.004f;
  float worst[2] = {1, 1};
  for (SurfaceScheme scheme : kSchemes) {
    const auto t = make(rows, cols, scheme, 8);
    SurfaceBuffers out;
    ASSERT_TRUE(t.tessellate(grid, out));
    for (int i = 0; i < t.patch_rows(); ++i)
      for (int j = 0; j + 1 < t.patch_cols(); ++j)
        for (int s = 0; s <= 8; ++s) {
          const float d = normal(out, sample(t, i, j, s, 8)).dot(normal(out, sample(t, i, j + 1, s, 0)));
          worst[int(scheme)] = std::min(worst[int(scheme)], d);
        }
  }
  EXPECT_GT(worst[int(SurfaceScheme::bspline)], 0.9999f);
  EXPECT_LT(worst[int(SurfaceScheme::bezier)], 0.99f);
}

TEST(SurfaceGrid, DegenerateNormalsFallBackToTheNeighbours) {
  // Row 0 collapsed to one point (a fan, like a pole): ∂S/∂u vanishes there; the normal must
  // still be the plane's, unit and finite.
  const int rows = 7, cols = 7;
  std::vector<Vec3f> grid(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) grid[size_t(r) * cols + c] = Vec3f(r * (c - 3.0f) * 0.001f, 0.0f, -0.001f * r);
  for (SurfaceScheme scheme : kSchemes) {
    const auto t = make(rows, cols, scheme, 4);
    SurfaceBuffers out;
    ASSERT_TRUE(t.tessellate(grid, out));
    for (size_t i = 0; i < out.point_count(); ++i) {
      const Vec3f n = normal(out, i);
      ASSERT_TRUE(n.allFinite());
      EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
      EXPECT_GT(n.dot(Vec3f::UnitY()), 0.999f) << name(scheme) << " point " << i;
    }
  }
  // A grid collapsed to a single point: normals fall back to +y.
  std::vector<Vec3f> collapsed(16, Vec3f(1, 2, 3));
  const auto t = make(4, 4, SurfaceScheme::bezier, 3);
  SurfaceBuffers out;
  ASSERT_TRUE(t.tessellate(collapsed, out));
  for (size_t i = 0; i < out.point_count(); ++i) EXPECT_EQ(normal(out, i), Vec3f::UnitY());
}

TEST(SurfaceGrid, RejectsBadGridsWithClearErrors) {
  auto a = SurfaceTessellator::build(1, 5);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().message, "surface (bezier): control grid is 1 x 5; expected at least 2 x 2 control points");
  auto b = SurfaceTessellator::build(4, 4, SurfaceDef{SurfaceScheme::bspline, 0});
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().message,
            "surface (bspline): resolution 0 is out of range; expected 1 to 1024 segments per patch edge");
  auto c = palpate::tessellate_grid(random_grid(3, 3, 1), 4, 4);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().message, "surface: 9 control points for a 4 x 4 grid; expected 16");
  // The per-frame call refuses mismatched sizes instead of reading out of bounds.
  const auto t = make(4, 4, SurfaceScheme::bezier, 2);
  SurfaceBuffers out;
  EXPECT_FALSE(t.tessellate(random_grid(4, 3, 1), out));
  EXPECT_TRUE(out.positions.empty());
  std::vector<float> p(3 * t.point_count()), n(3 * t.point_count() - 3);
  EXPECT_FALSE(t.tessellate(random_grid(4, 4, 1), p, n));
}

TEST(SurfaceGrid, FineResolutionsAgreeWithDirectEvaluation) {
  // Rows longer than the kernel's 64-sample chunks, and the noexcept span entry point.
  for (SurfaceScheme scheme : kSchemes) {
    const int rows = 5, cols = 6, r = 100;
    const auto grid = random_grid(rows, cols, 9);
    const auto t = make(rows, cols, scheme, r);
    std::vector<float> p(3 * t.point_count()), n(3 * t.point_count());
    ASSERT_TRUE(t.tessellate(grid, p, n));
    for (int i = 0; i < t.patch_rows(); ++i)
      for (int j = 0; j < t.patch_cols(); ++j)
        for (int a = 0; a <= r; a += 7)
          for (int b = 0; b <= r; ++b) {
            const size_t k = sample(t, i, j, a, b);
            const auto sp = t.evaluate(grid, i, j, float(b) / r, float(a) / r);
            EXPECT_LT((sp.position - Vec3f(p[3 * k], p[3 * k + 1], p[3 * k + 2])).norm(), 1e-5f)
                << name(scheme) << " patch " << i << "," << j << " sample " << a << "," << b;
            EXPECT_GT(sp.normal.dot(Vec3f(n[3 * k], n[3 * k + 1], n[3 * k + 2])), 0.9999f)
                << name(scheme) << " patch " << i << "," << j << " sample " << a << "," << b;
          }
  }
}

TEST(SurfaceGrid, SmoothedBorderNormalsAgreeAcrossEveryPatchBorderAndStayUnit) {
  // The dented grid of the test above, drawn with its border normals shared (smooth_border_normals):
  // at every left/right and top/bottom border the two patches' normals are the same unit vector,
  // a corner's four the same, and interior samples keep the analytic normal.
  const int rows = 10, cols = 10, res = 8;
  std::vector<Vec3f> grid(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) grid[size_t(r) * cols + c] = Vec3f(0.001f * c, 0, -0.001f * r);
  grid[size_t(4) * cols + 4].y() = -0.004f;
  const auto t = make(rows, cols, SurfaceScheme::bezier, res);
  SurfaceBuffers out;
  ASSERT_TRUE(t.tessellate(grid, out));
  const SurfaceBuffers raw = out;
  ASSERT_TRUE(t.smooth_border_normals(out.normals));
  float worst = 1;
  for (int i = 0; i < t.patch_rows(); ++i)
    for (int j = 0; j < t.patch_cols(); ++j)
      for (int s = 0; s <= res; ++s) {
        if (j + 1 < t.patch_cols())
          worst = std::min(worst, normal(out, sample(t, i, j, s, res)).dot(normal(out, sample(t, i, j + 1, s, 0))));
        if (i + 1 < t.patch_rows())
          worst = std::min(worst, normal(out, sample(t, i, j, res, s)).dot(normal(out, sample(t, i + 1, j, 0, s))));
      }
  EXPECT_GT(worst, 0.99999f);
  for (size_t k = 0; k < out.point_count(); ++k) EXPECT_NEAR(normal(out, k).norm(), 1.0f, 1e-5f) << k;
  // A corner shared by four patches: one normal.
  const Vec3f c = normal(out, sample(t, 0, 0, res, res));
  EXPECT_GT(c.dot(normal(out, sample(t, 1, 1, 0, 0))), 0.99999f);
  EXPECT_GT(c.dot(normal(out, sample(t, 0, 1, res, 0))), 0.99999f);
  EXPECT_GT(c.dot(normal(out, sample(t, 1, 0, 0, res))), 0.99999f);
  // Interior samples untouched; positions untouched.
  EXPECT_EQ(normal(out, sample(t, 1, 1, 4, 4)), normal(raw, sample(t, 1, 1, 4, 4)));
  EXPECT_EQ(out.positions, raw.positions);
  std::vector<float> wrong(3);
  EXPECT_FALSE(t.smooth_border_normals(wrong));
}

TEST(SurfaceGrid, AHexagonalLatticesRaggedEndsAreStraightenedAndASquareGridIsLeftAlone) {
  // Odd rows half a spacing along the rows (the charged-particle layout): column 0 of an odd row
  // lies 0.5 inward, the last column of an even row 0.5 inward. Straightened, every row's first
  // point is at x = 0 and its last at x = cols − 0.5; the points between are not moved.
  const int rows = 7, cols = 6;
  std::vector<Vec3f> hex(size_t(rows) * cols), square(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      hex[size_t(r) * cols + c] = Vec3f(c + 0.5f * (r & 1), 0.2f * r * r * 0.01f, 0.866f * r);
      square[size_t(r) * cols + c] = Vec3f(c, 0, r);
    }
  std::vector<Vec3f> h = hex, s = square;
  ASSERT_TRUE(palpate::straighten_grid_ends(h, rows, cols));
  ASSERT_TRUE(palpate::straighten_grid_ends(s, rows, cols));
  EXPECT_EQ(s, square);
  for (int r = 0; r < rows; ++r) {
    EXPECT_NEAR(h[size_t(r) * cols].x(), 0.0f, 1e-5f) << r;
    EXPECT_NEAR(h[size_t(r) * cols + cols - 1].x(), cols - 0.5f, 1e-5f) << r;
    for (int c = 1; c + 1 < cols; ++c) EXPECT_EQ(h[size_t(r) * cols + c], hex[size_t(r) * cols + c]) << r << " " << c;
  }
  std::vector<Vec3f> few(5);
  EXPECT_FALSE(palpate::straighten_grid_ends(few, rows, cols));
}
