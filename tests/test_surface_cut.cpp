// test_surface_cut.cpp — a grid surface with a cut (src/surface/grid_surface.cpp: grid_cut_cells,
// SurfaceTessellator::cut; docs/models/cutting.md): which cells a cut link marks, which triangles
// go, the walls along what is left, and nothing changed where nothing is cut — for both schemes;
// GridDrawing, the same drawn every frame with the cut laid out only when it changes.
#include <palpate/surface.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

namespace {

using namespace palpate;

// A flat rows x cols grid in the x-z plane, 1 mm apart, y = 0.
std::vector<Vec3f> flat_grid(int rows, int cols) {
  std::vector<Vec3f> g;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) g.emplace_back(0.001f * c, 0.0f, 0.001f * r);
  return g;
}

TEST(SurfaceCut, ACutLinkMarksTheCellsWithBothItsEndsAsCorners) {
  const int rows = 5, cols = 6;
  std::vector<std::uint8_t> cells(size_t((rows - 1) * (cols - 1)));
  auto id = [&](int r, int c) { return r * cols + c; };
  auto cell = [&](int r, int c) { return cells[size_t(r * (cols - 1) + c)]; };
  // A diagonal: the one cell it crosses. A link along a row: the cells above and below it. One
  // along a column: left and right. On the border: the one cell there is. Not neighbours: ignored.
  const std::vector<std::array<int, 2>> links = {{id(1, 1), id(2, 2)}, {id(3, 3), id(3, 4)}, {id(0, 4), id(1, 4)},
                                                 {id(0, 0), id(0, 1)}, {id(0, 0), id(4, 5)}, {-1, 3}};
  ASSERT_TRUE(grid_cut_cells(rows, cols, links, cells));
  std::vector<std::uint8_t> want(cells.size(), 0);
  for (auto [r, c] : {std::pair{1, 1}, std::pair{2, 3}, std::pair{3, 3}, std::pair{0, 3}, std::pair{0, 4}, std::pair{0, 0}})
    want[size_t(r * (cols - 1) + c)] = 1;
  EXPECT_EQ(cells, want);
  EXPECT_EQ(cell(1, 1), 1);
  std::vector<std::uint8_t> wrong(3);
  EXPECT_FALSE(grid_cut_cells(rows, cols, links, wrong));
}

TEST(SurfaceCut, TrianglesOverCutCellsGoAndWallsLineWhatIsLeft) {
  for (SurfaceScheme scheme : {SurfaceScheme::bezier, SurfaceScheme::bspline}) {
    const int rows = 10, cols = 10;
    const auto control = flat_grid(rows, cols);
    auto t = SurfaceTessellator::build(rows, cols, SurfaceDef{scheme, 6});
    ASSERT_TRUE(t.ok());
    SurfaceBuffers out;
    ASSERT_TRUE(t->tessellate(control, out));
    const SurfaceBuffers whole = out;
    // Cut the cells of row 4 (between control rows 4 and 5), columns 2..6: a slot inside the grid.
    std::vector<std::uint8_t> cells(size_t((rows - 1) * (cols - 1)), 0);
    for (int c = 2; c <= 6; ++c) cells[size_t(4 * (cols - 1) + c)] = 1;
    ASSERT_TRUE(t->cut(cells, 0.003f, out));
    const size_t n = t->point_count();
    const auto tri_cells = t->triangle_cells();
    ASSERT_EQ(tri_cells.size(), whole.triangle_count());
    size_t kept = 0, walls = 0;
    for (size_t k = 0; k < out.triangle_count(); ++k) {
      const uint32_t* tri = &out.triangles[3 * k];
      if (tri[0] >= n) {
        ++walls;
        for (int c = 0; c < 3; ++c) {
          // Wall points: on the slot's rim or 3 mm behind it (against the surface's normal, which
          // is du × dv = x × z = −y here), their normals level (into the slot).
          const float y = out.positions[3 * tri[c] + 1];
          EXPECT_TRUE(std::abs(y) < 1e-6f || std::abs(y - 0.003f) < 1e-6f) << y;
          EXPECT_NEAR(out.normals[3 * tri[c] + 1], 0.0f, 1e-5f);
        }
        continue;
      }
      ++kept;
      // A surface triangle is one of the whole surface's, and not over the slot: its centroid lies
      // outside the slot's rectangle (x 2..7 mm, z 4..5 mm).
      float x = 0, z = 0;
      for (int c = 0; c < 3; ++c) x += out.positions[3 * tri[c]] / 3, z += out.positions[3 * tri[c] + 2] / 3;
      EXPECT_FALSE(x > 0.002f && x < 0.007f && z > 0.004f && z < 0.005f) << "triangle " << k << " over the cut";
    }
    size_t over = 0;
    for (int32_t cell : tri_cells) over += cells[size_t(cell)];
    EXPECT_EQ(kept, whole.triangle_count() - over);
    EXPECT_GT(over, 0u);
    EXPECT_GT(walls, 0u);
    // Uncut: untouched; and the next tessellate() is the whole surface again.
    SurfaceBuffers again = whole;
    std::fill(cells.begin(), cells.end(), 0);
    ASSERT_TRUE(t->cut(cells, 0.003f, again));
    EXPECT_EQ(again.triangles, whole.triangles);
    EXPECT_EQ(again.positions, whole.positions);
    ASSERT_TRUE(t->tessellate(control, out));
    EXPECT_EQ(out.triangles, whole.triangles);
    EXPECT_EQ(out.positions, whole.positions);
  }
}

TEST(SurfaceCut, AGridDrawingIsTheOneOffCutAndLaysItOutAgainOnlyWhenTheCutChanges) {
  // A wavy 10 x 12 grid (so that normals and walls differ from point to point), cut along the
  // links between control rows 4 and 5 over columns 2..7.
  const int rows = 10, cols = 12;
  std::vector<Vec3f> points = flat_grid(rows, cols);
  for (Vec3f& p : points) p.y() = 0.0004f * std::sin(900.0f * p.x()) * std::cos(700.0f * p.z());
  std::vector<std::array<int, 2>> links;
  for (int c = 2; c <= 7; ++c) links.push_back({4 * cols + c, 5 * cols + c});
  const float thickness = 0.002f;
  const SurfaceDef def{SurfaceScheme::bezier, 5};
  // What a frame draws in one go: straightened ends, tessellated, border normals shared, cut().
  const auto one_off = [&](const std::vector<Vec3f>& pts, std::span<const std::array<int, 2>> cut) {
    auto t = SurfaceTessellator::build(rows, cols, def);
    SurfaceBuffers out;
    std::vector<Vec3f> control = pts;
    straighten_grid_ends(control, rows, cols);
    EXPECT_TRUE(t->tessellate(control, out) && t->smooth_border_normals(out.normals));
    std::vector<std::uint8_t> cells(size_t((rows - 1) * (cols - 1)));
    EXPECT_TRUE(grid_cut_cells(rows, cols, cut, cells) && t->cut(cells, thickness, out));
    return out;
  };
  auto d = GridDrawing::build(rows, cols, def);
  ASSERT_TRUE(d.ok()) << d.error().message;
  const auto same = [&](const SurfaceBuffers& want) {
    EXPECT_EQ(std::vector<float>(d->positions().begin(), d->positions().end()), want.positions);
    EXPECT_EQ(std::vector<float>(d->normals().begin(), d->normals().end()), want.normals);
    EXPECT_EQ(std::vector<uint32_t>(d->triangles().begin(), d->triangles().end()), want.triangles);
  };
  // Uncut: the whole surface, laid out once at build.
  ASSERT_TRUE(d->draw(points, {}, thickness));
  same(one_off(points, {}));
  EXPECT_EQ(d->layout_revision(), 0u);
  EXPECT_EQ(d->triangles().size(), d->tessellator().triangles().size());
  // Cut: laid out again, and the same as the one-off cut, walls and all.
  ASSERT_TRUE(d->draw(points, links, thickness));
  same(one_off(points, links));
  EXPECT_EQ(d->layout_revision(), 1u);
  EXPECT_GT(d->positions().size(), 3 * d->tessellator().point_count()) << "walls were added";
  // The surface moves (the wound opens), the cut stays: the layout and its index buffer stay
  // (the same array, not reallocated), the points — the walls' too — follow the surface.
  const uint32_t* indices = d->triangles().data();
  const std::vector<float> before(d->positions().begin(), d->positions().end());
  for (Vec3f& p : points) p.z() += p.z() > 0.0045f ? 0.0005f : -0.0005f;
  ASSERT_TRUE(d->draw(points, links, thickness));
  same(one_off(points, links));
  EXPECT_EQ(d->layout_revision(), 1u);
  EXPECT_EQ(d->triangles().data(), indices);
  const size_t n = 3 * d->tessellator().point_count();
  EXPECT_FALSE(std::equal(before.begin() + long(n), before.end(), d->positions().begin() + long(n)))
      << "the walls moved with the surface";
  // A longer cut: laid out again; healed (no cut links): the whole surface again.
  links.push_back({4 * cols + 8, 5 * cols + 8});
  ASSERT_TRUE(d->draw(points, links, thickness));
  same(one_off(points, links));
  EXPECT_EQ(d->layout_revision(), 2u);
  ASSERT_TRUE(d->draw(points, {}, thickness));
  same(one_off(points, {}));
  EXPECT_EQ(d->layout_revision(), 3u);
  // Wrong sizes: refused, the last drawing kept.
  points.pop_back();
  EXPECT_FALSE(d->draw(points, {}, thickness));
  EXPECT_EQ(d->layout_revision(), 3u);
}

}  // namespace
