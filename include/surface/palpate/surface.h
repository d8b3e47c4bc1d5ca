// palpate/surface.h — smooth surfaces drawn over particles: bicubic Bézier / B-spline patches over
// a control grid, and PN triangles over a triangle mesh. Plain arrays out; no OpenGL here.
#pragma once

#include <palpate/core.h>

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace palpate {

struct SurfaceMesh;

// A tessellated surface as plain arrays, ready for a renderer (or a file).
struct SurfaceBuffers {
  std::vector<float> positions;      // (#P x 3) m
  std::vector<float> normals;        // (#P x 3) unit, on the side the triangles face
  std::vector<uint32_t> triangles;   // (#T x 3) indices into positions, counter-clockwise seen
                                     // from the side the normals point to
  size_t point_count() const { return positions.size() / 3; }
  size_t triangle_count() const { return triangles.size() / 3; }
};

// How a control grid becomes a surface.
enum class SurfaceScheme {
  // The seed paper's: interconnected bicubic Bézier patches, 16 control points each. Patch (i,j)
  // uses control rows 3i..3i+3 and columns 3j..3j+3; neighbours share their border row/column,
  // so the surface is C⁰ (creases along patch borders where the grid bends there). The surface
  // interpolates every control point whose row and column are multiples of 3.
  bezier,
  // Uniform bicubic B-spline over the same grid: one span between each pair of neighbouring
  // rows/columns, C² everywhere. The grid is extended by one phantom row/column on every side,
  // P₋₁ = 2P₀ − P₁, so the surface reaches the grid's border and interpolates its corners and
  // boundary end points; it never leaves the convex hull of the (real) control points.
  bspline,
};

struct SurfaceDef {
  SurfaceScheme scheme = SurfaceScheme::bezier;
  int resolution = 8;  // segments along each edge of a patch (or B-spline span): (r+1)² points each
};

// The value and partial derivatives of a grid surface at one parameter point.
struct SurfacePoint {
  Vec3f position = Vec3f::Zero();  // m
  Vec3f du = Vec3f::Zero();        // ∂S/∂u, m per unit parameter; u runs along the grid's columns
  Vec3f dv = Vec3f::Zero();        // ∂S/∂v; v runs along the grid's rows
  Vec3f duu = Vec3f::Zero(), duv = Vec3f::Zero(), dvv = Vec3f::Zero();  // second derivatives
  Vec3f normal = Vec3f::UnitY();   // unit du × dv; +y where du × dv vanishes
};

// Tessellates a rows x cols row-major control grid (control point (r,c) at index r*cols + c) at a
// fixed resolution per patch, independent of the particle count. Built once per grid size and
// resolution (the basis values, index tables and triangles are precomputed); `tessellate` is
// then allocation-free and can run every frame; it is const and keeps no scratch, so threads may
// share one tessellator (each with its own output).
//
// Leftover rows/columns (Bézier with rows−1 or cols−1 not a multiple of 3): the last patch in
// that direction takes the 2 or 3 remaining rows and is their line or quadratic Bézier curve,
// degree-elevated to a cubic (P0, (2P0+P1)/3, (P0+2P1)/3, P1 and P0, (P0+2P1)/3, (2P1+P2)/3, P2).
// So every particle is used, the surface ends exactly at the grid's last row/column, and no
// derivative vanishes there, as plain clamping (repeating the last row) would make it.
//
// Output points are grouped by patch: patch (i,j) owns points [k·(r+1)², (k+1)·(r+1)²), with
// k = i·patch_cols() + j, row-major in (v, u). Border points are repeated in both patches (equal
// positions), so each patch keeps its own normals: Bézier creases stay visible as in the paper.
// For display only: a hexagonal lattice's ragged ends made straight. In a grid whose odd rows sit
// half a spacing along the rows from the even ones (charged-particle patches), the first and last
// columns zigzag by half a spacing and the surface drawn through them has a sawtooth edge. Each end
// point that lies inward of its neighbouring rows' ends (by more than a quarter of its row's first
// step) is moved outward along its row to their line; the others, and a square grid, are left as
// they are. Works on the deformed grid as it is (no rest state). noexcept, no allocation; false,
// changing nothing, when control.size() != rows·cols or rows < 3 or cols < 2.
bool straighten_grid_ends(std::span<Vec3f> control, int rows, int cols) noexcept;

// Which cells of a rows x cols control grid a cut runs through (docs/models/cutting.md): cell
// (r, c) lies between control rows r, r+1 and columns c, c+1, index r·(cols−1) + c; `cells`
// ((rows−1) x (cols−1)) is set to 1 where a cut link (two control points, as TissueSnapshot's
// cut_links) joins two of the cell's corners, 0 elsewhere. Links that are not between corners of
// one cell are ignored. noexcept, no allocation; false, changing nothing, on wrong sizes.
bool grid_cut_cells(int rows, int cols, std::span<const std::array<int, 2>> cut_links,
                    std::span<std::uint8_t> cells) noexcept;

// What a cut leaves of a tessellated grid (SurfaceTessellator::cut_layout): depends on which cells
// are cut, not on where the surface is.
struct SurfaceCutLayout {
  size_t surface_points = 0;        // the tessellator's point_count(); wall points follow them
  std::vector<uint32_t> triangles;  // (#T x 3) the kept surface triangles, then two per wall
  // (#W) per wall: the two surface points of the side it stands on (p, q), then the four corners
  // of the kept sample quad it bounds (whose centre says which way the wound lies).
  std::vector<std::array<uint32_t, 6>> walls;
  size_t point_count() const { return surface_points + 4 * walls.size(); }
};

class SurfaceTessellator {
 public:
  // Fails (an Error saying which value and what was expected) for rows or cols < 2, a
  // resolution outside [1, 1024], or a grid whose output would exceed 2³² − 1 points.
  static Result<SurfaceTessellator> build(int rows, int cols, const SurfaceDef& def = {});

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  const SurfaceDef& def() const { return def_; }
  int patch_rows() const { return patch_rows_; }  // patches along v
  int patch_cols() const { return patch_cols_; }  // patches along u
  size_t point_count() const;
  size_t triangle_count() const { return triangles_.size() / 3; }
  // (#T x 3) triangle indices, the same every frame.
  std::span<const uint32_t> triangles() const { return triangles_; }

  // Sizes `out` (allocates only the first time) and fills it for these control points.
  // Returns false, leaving `out` alone, when control.size() != rows*cols.
  bool tessellate(std::span<const Vec3f> control, SurfaceBuffers& out) const;

  // The per-frame path: positions and normals (each point_count()*3 floats) for these control
  // points. noexcept, no allocation. Normals are (∂S/∂u × ∂S/∂v)/|…| from the analytic
  // derivatives; where that cross product vanishes (collapsed control points) the normal comes
  // from the neighbouring samples' positions, and failing that, from the patch's corner
  // diagonals, and failing that (a patch collapsed to a point or a line) it is +y.
  // Returns false, writing nothing, when a span has the wrong size.
  bool tessellate(std::span<const Vec3f> control, std::span<float> positions,
                  std::span<float> normals) const noexcept;

  // For display only (the viewer, frames): the normals of each border point repeated in two to four
  // patches averaged and renormalised, so the shading runs on across the patches instead of lighting
  // each patch as its own facet (the creases above: blocky highlights on a curved organ).
  // noexcept, no allocation; false, changing nothing, when `normals` has the wrong size.
  bool smooth_border_normals(std::span<float> normals) const noexcept;

  // A cut surface, after tessellate(control, out): the triangles over cut cells (grid_cut_cells)
  // are dropped, so no triangle bridges a wound, and each border this opens gets a side wall
  // `thickness` (m) deep against the surface's normals — the cut layer's face, so the wound shows
  // its edges' thickness. Wall points are appended after point_count() (each with the wall's normal,
  // facing into the wound). With no cell cut, `out` is left exactly as tessellate made it.
  // Allocates (like the tessellate above: not for the haptic thread). False on wrong sizes.
  bool cut(std::span<const std::uint8_t> cells, float thickness, SurfaceBuffers& out) const;
  // cut() in two phases, for a surface drawn every frame (the viewer; GridDrawing below):
  // cut_layout, when the cut changes, lists the kept triangles and the walls (which sides of kept
  // sample quads face a dropped one; it allocates); cut_walls, every frame after tessellate(),
  // places the walls' points on the surface as it is now (noexcept, no allocation). Together they
  // give what cut() gives. False on wrong sizes (`positions`, `normals`: layout.point_count()·3
  // floats, the surface's first).
  bool cut_layout(std::span<const std::uint8_t> cells, SurfaceCutLayout& layout) const;
  bool cut_walls(const SurfaceCutLayout& layout, float thickness, std::span<float> positions,
                 std::span<float> normals) const noexcept;
  // The control-grid cell each output triangle lies over (its sample quad's centre), as
  // grid_cut_cells numbers them: (#T).
  std::span<const std::int32_t> triangle_cells() const { return triangle_cell_; }

  // The surface at patch (i,j), parameters u, v ∈ [0,1] (u along columns), at any parameter
  // (from the basis polynomials, not the sample tables): for tests and picking, not per frame.
  SurfacePoint evaluate(std::span<const Vec3f> control, int patch_i, int patch_j, float u,
                        float v) const;

  // Which control points patch (i,j) depends on: control point index for each of the 4 slots
  // along v (rows) and u (columns); a slot may repeat an index (with a zero or combined weight).
  std::array<int, 4> patch_rows_of(int patch_i) const;
  std::array<int, 4> patch_cols_of(int patch_j) const;

 private:
  // One parameter direction's precomputed tables (built once).
  struct Axis {
    int patches = 0;
    std::vector<std::array<int, 4>> index;  // (#patches) control row/column of each slot
    std::vector<float> w;    // (#patches x 4 x (r+1)) basis value of each slot at each sample
    std::vector<float> dw;   // (#patches x 4 x (r+1)) its first derivative, per unit t
    std::vector<std::array<std::array<float, 4>, 4>> coef;  // (#patches) slot weights of the
                             // 4 cubic basis functions: slot a weighs Σ_k coef[a][k]·B_k(t)
  };

  void tessellate_patch(std::span<const Vec3f> control, int i, int j, float* positions,
                        float* normals) const noexcept;

  int rows_ = 0, cols_ = 0, patch_rows_ = 0, patch_cols_ = 0;
  SurfaceDef def_;
  Axis u_, v_;                       // u_: along columns, v_: along rows
  std::vector<uint32_t> triangles_;  // (#T x 3)
  std::vector<std::int32_t> triangle_cell_;  // (#T) the grid cell under each triangle
};

// A control grid as the viewer and the run's frames draw it (display only): the lattice's ends
// straightened (straighten_grid_ends), tessellated, the patches' border normals shared
// (smooth_border_normals), and where cut links are given (TissueSnapshot::cut_links), the wound
// cut open with walls `thickness` deep (grid_cut_cells, SurfaceTessellator::cut). The cut's layout
// is kept between draws and made again only when the cut links change, so a draw with the same
// cut allocates nothing and costs a tessellation, a comparison of the links and the walls' points.
class GridDrawing {
 public:
  // As SurfaceTessellator::build.
  static Result<GridDrawing> build(int rows, int cols, const SurfaceDef& def = {});

  // Draws these control points (rows·cols, row-major) with these cut links (pairs of control
  // point indices; a link not between corners of one grid cell cuts nothing). False, keeping the
  // last drawing, when points.size() != rows·cols.
  bool draw(std::span<const Vec3f> points, std::span<const std::array<int, 2>> cut_links, float thickness);

  const SurfaceTessellator& tessellator() const { return tess_; }
  std::span<const float> positions() const { return out_.positions; }  // (#P x 3) m
  std::span<const float> normals() const { return out_.normals; }      // (#P x 3) unit
  std::span<const uint32_t> triangles() const { return layout_.triangles; }  // (#T x 3)
  // The cut links the drawing is laid out for, and how many times it was laid out again (a new
  // index buffer): a renderer that uploads indices once re-uploads them when this changes.
  std::span<const std::array<int, 2>> cut_links() const { return cut_links_; }
  std::uint64_t layout_revision() const { return revision_; }
  // The arrays of the last draw, moved out (for a one-off drawing, as a frame makes).
  SurfaceBuffers take() &&;

 private:
  explicit GridDrawing(SurfaceTessellator tess) : tess_(std::move(tess)) {}
  SurfaceTessellator tess_;
  std::vector<Vec3f> control_;                   // (rows·cols) the points with their ends straightened
  SurfaceBuffers out_;                           // positions and normals; triangles unused
  std::vector<std::array<int, 2>> cut_links_;    // as last laid out
  std::vector<std::uint8_t> cells_;              // ((rows−1)·(cols−1)) grid_cut_cells' of them
  SurfaceCutLayout layout_;
  std::uint64_t revision_ = 0;
};

// Tessellate a control grid once (builds a tessellator; for per-frame use keep one instead).
Result<SurfaceBuffers> tessellate_grid(std::span<const Vec3f> control, int rows, int cols,
                                       const SurfaceDef& def = {});

// PN triangles (Vlachos, Peters, Boyd & Mitchell 2001, "Curved PN Triangles"): each triangle of a
// mesh with vertex normals becomes a cubic Bézier triangle (positions) with a quadratic normal
// field, split into level² small triangles. Flat input stays flat; the surface interpolates the
// vertices and their normals and is C⁰ along shared edges (an edge depends only on its two
// vertices). Built once per topology and level; `tessellate` is allocation-free per frame.
// Output vertices are welded: one per mesh vertex, level−1 per mesh edge, the rest per triangle.
class PnTessellator {
 public:
  // Fails for level outside [1, 64], an empty mesh, a vertex index out of range (naming the
  // triangle), or a triangle repeating a vertex.
  static Result<PnTessellator> build(int vertex_count, std::span<const std::array<int, 3>> triangles,
                                     int level);

  int level() const { return level_; }
  int vertex_count() const { return vertex_count_; }
  size_t point_count() const { return point_count_; }
  size_t triangle_count() const { return triangles_.size() / 3; }
  std::span<const uint32_t> triangles() const { return triangles_; }

  // Sizes `out` once and fills it; false (out untouched) when the spans' sizes do not match.
  bool tessellate(std::span<const Vec3f> positions, std::span<const Vec3f> normals,
                  SurfaceBuffers& out) const;
  // Per-frame path, noexcept and allocation-free. Input normals need not be unit; a zero normal
  // is replaced by the triangle's face normal.
  bool tessellate(std::span<const Vec3f> positions, std::span<const Vec3f> normals,
                  std::span<float> out_positions, std::span<float> out_normals) const noexcept;

 private:
  int vertex_count_ = 0, level_ = 1;
  size_t point_count_ = 0;
  std::vector<std::array<int, 3>> mesh_triangles_;  // (#F) the input triangles
  std::vector<uint32_t> sample_index_;  // (#F x samples per triangle) output point of each sample
  std::vector<std::array<float, 3>> bary_;  // (samples per triangle) barycentrics of each sample
  std::vector<uint32_t> triangles_;         // (#T x 3)
};

// A SurfaceMesh (double, libigl style) through PN triangles in one call.
Result<SurfaceBuffers> pn_triangles(const SurfaceMesh& mesh, int level);

}  // namespace palpate
