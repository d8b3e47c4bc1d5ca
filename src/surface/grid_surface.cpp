// grid_surface.cpp — bicubic Bézier and uniform B-spline surfaces over a particle control grid.
#include <palpate/surface.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include "core/simd.h"
#endif

namespace palpate {
namespace {

constexpr int kMaxResolution = 1024;

// The four cubic basis functions of a scheme and their first two derivatives at t ∈ [0,1].
//
// Bézier (Bernstein): B_k(t) = C(3,k) t^k (1−t)^(3−k).
// Uniform cubic B-spline (e.g. Farin, "Curves and Surfaces for CAGD", ch. 8, matrix form):
//   N0 = (1−t)³/6, N1 = (3t³ − 6t² + 4)/6, N2 = (−3t³ + 3t² + 3t + 1)/6, N3 = t³/6.
struct Cubic {
  std::array<float, 4> b, d1, d2;
};

Cubic cubic_basis(SurfaceScheme scheme, float t) {
  const float s = 1.0f - t;
  Cubic c;
  if (scheme == SurfaceScheme::bezier) {
    c.b = {s * s * s, 3 * t * s * s, 3 * t * t * s, t * t * t};
    c.d1 = {-3 * s * s, 3 * s * (1 - 3 * t), 3 * t * (2 - 3 * t), 3 * t * t};
    c.d2 = {6 * s, 18 * t - 12, 6 - 18 * t, 6 * t};
  } else {
    c.b = {s * s * s / 6, (3 * t * t * t - 6 * t * t + 4) / 6, (-3 * t * t * t + 3 * t * t + 3 * t + 1) / 6,
           t * t * t / 6};
    c.d1 = {-s * s / 2, (3 * t * t - 4 * t) / 2, (-3 * t * t + 2 * t + 1) / 2, t * t / 2};
    c.d2 = {s, 3 * t - 2, 1 - 3 * t, t};
  }
  return c;
}

// A control point of one cubic as a combination of real grid indices (at most 2 terms here:
// a phantom B-spline point 2P₀ − P₁, or a degree-elevated Bézier point).
struct Combo {
  std::array<int, 3> idx{};
  std::array<float, 3> weight{};
  int terms = 0;
  void add(int i, float w) {
    for (int k = 0; k < terms; ++k)
      if (idx[k] == i) {
        weight[k] += w;
        return;
      }
    idx[terms] = i;
    weight[terms] = w;
    ++terms;
  }
};

// The 4 virtual cubic control points of patch p along a direction of n grid points.
std::array<Combo, 4> patch_controls(SurfaceScheme scheme, int n, int p) {
  std::array<Combo, 4> ctrl;
  if (scheme == SurfaceScheme::bezier) {
    const int s = 3 * p;
    const int k = std::min(3, n - 1 - s);  // segments left: 3 (full), 2 (quadratic) or 1 (line)
    if (k == 3) {
      for (int a = 0; a < 4; ++a) ctrl[a].add(s + a, 1.0f);
    } else if (k == 2) {  // quadratic a, b, c elevated: a, (a+2b)/3, (2b+c)/3, c
      ctrl[0].add(s, 1.0f);
      ctrl[1].add(s, 1.0f / 3), ctrl[1].add(s + 1, 2.0f / 3);
      ctrl[2].add(s + 1, 2.0f / 3), ctrl[2].add(s + 2, 1.0f / 3);
      ctrl[3].add(s + 2, 1.0f);
    } else {  // line a, b elevated: a, (2a+b)/3, (a+2b)/3, b
      ctrl[0].add(s, 1.0f);
      ctrl[1].add(s, 2.0f / 3), ctrl[1].add(s + 1, 1.0f / 3);
      ctrl[2].add(s, 1.0f / 3), ctrl[2].add(s + 1, 2.0f / 3);
      ctrl[3].add(s + 1, 1.0f);
    }
  } else {
    // Span p uses extended points p−1 .. p+2; the phantoms beyond each end are reflections
    // 2P₀ − P₁ and 2P_{n−1} − P_{n−2}, which make the curve interpolate the end points.
    for (int k = 0; k < 4; ++k) {
      const int e = p - 1 + k;
      if (e < 0) {
        ctrl[k].add(0, 2.0f), ctrl[k].add(1, -1.0f);
      } else if (e > n - 1) {
        ctrl[k].add(n - 1, 2.0f), ctrl[k].add(n - 2, -1.0f);
      } else {
        ctrl[k].add(e, 1.0f);
      }
    }
  }
  return ctrl;
}

int patch_count(SurfaceScheme scheme, int n) {
  return scheme == SurfaceScheme::bezier ? (n - 1 + 2) / 3 : n - 1;
}

// Fold a patch's virtual control points into 4 slots over a window of consecutive real indices,
// so the per-frame kernel gathers 4 real points and applies combined basis weights.
void fill_slots(const std::array<Combo, 4>& ctrl, int n, std::array<int, 4>& index,
                std::array<std::array<float, 4>, 4>& coef) {
  int lo = n, hi = -1;
  for (const Combo& c : ctrl)
    for (int t = 0; t < c.terms; ++t) lo = std::min(lo, c.idx[t]), hi = std::max(hi, c.idx[t]);
  assert(hi - lo <= 3);
  (void)hi;
  const int base = std::max(0, std::min(lo, n - 4));
  for (int a = 0; a < 4; ++a) index[a] = std::min(base + a, n - 1);
  for (auto& row : coef) row.fill(0.0f);
  for (int k = 0; k < 4; ++k)
    for (int t = 0; t < ctrl[k].terms; ++t) {
      const int slot = ctrl[k].idx[t] - base;  // first slot holding that index
      coef[slot][k] += ctrl[k].weight[t];
    }
}

constexpr int kChunk = 64;  // samples per structure-of-arrays chunk of a row

// inv[i] = ok[i] / sqrt(c2[i]) for i < n (0 where ok[i] is 0); returns how many ok[i] are 0.
// Written with SSE where the target has it: std::sqrt's errno rule stops GCC vectorising it.
int inverse_norms(const float* c2, const float* ok, float* inv, int n) noexcept {
  int i = 0;
  float bad = 0;
#if defined(__SSE2__)
  using namespace simd;
  f4 bad4 = zero<f4>();
  const f4 one = broadcast<f4>(1.0f), smallest = broadcast<f4>(std::numeric_limits<float>::min());
  for (; i + 4 <= n; i += 4) {
    const f4 k = loadu<f4>(ok + i);
    storeu(inv + i, k / sqrt(max(loadu<f4>(c2 + i), smallest)));
    bad4 = bad4 + (one - k);
  }
  bad = sum(bad4);
#endif
  for (; i < n; ++i) {
    inv[i] = ok[i] != 0.0f ? 1.0f / std::sqrt(c2[i]) : 0.0f;
    bad += 1.0f - ok[i];
  }
  return int(bad);
}

std::string scheme_name(SurfaceScheme s) { return s == SurfaceScheme::bezier ? "bezier" : "bspline"; }

}  // namespace

// --- build ---------------------------------------------------------------------------------------

Result<SurfaceTessellator> SurfaceTessellator::build(int rows, int cols, const SurfaceDef& def) {
  const std::string where = "surface (" + scheme_name(def.scheme) + "): ";
  if (rows < 2 || cols < 2)
    return Error{where + "control grid is " + std::to_string(rows) + " x " + std::to_string(cols) +
                 "; expected at least 2 x 2 control points"};
  if (def.resolution < 1 || def.resolution > kMaxResolution)
    return Error{where + "resolution " + std::to_string(def.resolution) + " is out of range; expected 1 to " +
                 std::to_string(kMaxResolution) + " segments per patch edge"};
  SurfaceTessellator t;
  t.rows_ = rows;
  t.cols_ = cols;
  t.def_ = def;
  t.patch_rows_ = patch_count(def.scheme, rows);
  t.patch_cols_ = patch_count(def.scheme, cols);
  const int r1 = def.resolution + 1;
  const uint64_t points = uint64_t(t.patch_rows_) * uint64_t(t.patch_cols_) * uint64_t(r1) * uint64_t(r1);
  if (points > std::numeric_limits<uint32_t>::max())
    return Error{where + std::to_string(points) + " points for a " + std::to_string(rows) + " x " +
                 std::to_string(cols) + " grid at resolution " + std::to_string(def.resolution) +
                 "; expected at most 4294967295 (32-bit indices)"};

  auto fill = [&](int n, Axis& ax) {
    ax.patches = patch_count(def.scheme, n);
    ax.index.resize(ax.patches);
    ax.coef.resize(ax.patches);
    ax.w.assign(size_t(ax.patches) * 4 * r1, 0.0f);
    ax.dw.assign(size_t(ax.patches) * 4 * r1, 0.0f);
    for (int p = 0; p < ax.patches; ++p) {
      fill_slots(patch_controls(def.scheme, n, p), n, ax.index[p], ax.coef[p]);
      for (int s = 0; s < r1; ++s) {
        // Exact end samples so neighbouring patches' border points are bitwise equal.
        const float tt = s == def.resolution ? 1.0f : float(s) / float(def.resolution);
        const Cubic c = cubic_basis(def.scheme, tt);
        for (int a = 0; a < 4; ++a) {
          float w = 0, dw = 0;
          for (int k = 0; k < 4; ++k) w += ax.coef[p][a][k] * c.b[k], dw += ax.coef[p][a][k] * c.d1[k];
          ax.w[(size_t(p) * 4 + a) * r1 + s] = w;
          ax.dw[(size_t(p) * 4 + a) * r1 + s] = dw;
        }
      }
    }
  };
  fill(cols, t.u_);
  fill(rows, t.v_);

  // Triangles, counter-clockwise seen from du × dv: (0,0) → (u+1) → (u+1,v+1), and so on.
  const size_t per_patch = size_t(r1) * r1;
  const int res = def.resolution;
  t.triangles_.reserve(size_t(t.patch_rows_) * t.patch_cols_ * res * res * 6);
  for (size_t patch = 0; patch < size_t(t.patch_rows_) * t.patch_cols_; ++patch) {
    const uint32_t base = uint32_t(patch * per_patch);
    for (int a = 0; a < res; ++a)
      for (int b = 0; b < res; ++b) {
        const uint32_t p00 = base + uint32_t(a * r1 + b), p01 = p00 + 1, p10 = p00 + uint32_t(r1),
                       p11 = p10 + 1;
        t.triangles_.insert(t.triangles_.end(), {p00, p01, p11, p00, p11, p10});
      }
  }
  // The grid cell under each sample quad's centre: a Bézier patch spans the 3 (or its leftover 2
  // or 1) cells from control index 3p, a B-spline span one cell.
  auto cell_of = [&](int n, int patch, double at) {
    if (def.scheme == SurfaceScheme::bspline) return patch;
    const int first = 3 * patch, k = std::min(3, n - 1 - first);
    return first + std::min(k - 1, int(std::floor(at * k)));
  };
  t.triangle_cell_.reserve(t.triangles_.size() / 3);
  for (int pi = 0; pi < t.patch_rows_; ++pi)
    for (int pj = 0; pj < t.patch_cols_; ++pj)
      for (int a = 0; a < res; ++a)
        for (int b = 0; b < res; ++b) {
          const int r = cell_of(rows, pi, (a + 0.5) / res), c = cell_of(cols, pj, (b + 0.5) / res);
          const std::int32_t cell = std::int32_t(r * (cols - 1) + c);
          t.triangle_cell_.insert(t.triangle_cell_.end(), {cell, cell});
        }
  return t;
}

bool grid_cut_cells(int rows, int cols, std::span<const std::array<int, 2>> cut_links,
                    std::span<std::uint8_t> cells) noexcept {
  if (rows < 2 || cols < 2 || cells.size() != size_t(rows - 1) * size_t(cols - 1)) return false;
  std::fill(cells.begin(), cells.end(), std::uint8_t{0});
  const long n = long(rows) * long(cols);
  for (const auto& [i, j] : cut_links) {
    if (i < 0 || j < 0 || i >= n || j >= n) continue;
    const int ri = int(i / cols), ci = int(i % cols), rj = int(j / cols), cj = int(j % cols);
    if (std::abs(ri - rj) > 1 || std::abs(ci - cj) > 1 || i == j) continue;
    // Every cell having both as corners: one for a diagonal, the two either side for a row or
    // column link.
    const int r0 = std::min(ri, rj), c0 = std::min(ci, cj);
    for (int r = (ri == rj ? r0 - 1 : r0); r <= r0; ++r)
      for (int c = (ci == cj ? c0 - 1 : c0); c <= c0; ++c)
        if (r >= 0 && c >= 0 && r < rows - 1 && c < cols - 1) cells[size_t(r) * size_t(cols - 1) + size_t(c)] = 1;
  }
  return true;
}

bool SurfaceTessellator::cut(std::span<const std::uint8_t> cells, float thickness, SurfaceBuffers& out) const {
  const size_t n = point_count();
  if (cells.size() != size_t(rows_ - 1) * size_t(cols_ - 1) || out.positions.size() < 3 * n ||
      out.normals.size() != out.positions.size())
    return false;
  if (std::none_of(cells.begin(), cells.end(), [](std::uint8_t c) { return c != 0; })) return true;
  SurfaceCutLayout layout;
  if (!cut_layout(cells, layout)) return false;
  // Sized for this cut's walls (dropping an earlier cut()'s).
  out.positions.resize(3 * layout.point_count()), out.normals.resize(3 * layout.point_count());
  if (!cut_walls(layout, thickness, out.positions, out.normals)) return false;
  out.triangles = std::move(layout.triangles);
  return true;
}

bool SurfaceTessellator::cut_layout(std::span<const std::uint8_t> cells, SurfaceCutLayout& layout) const {
  if (cells.size() != size_t(rows_ - 1) * size_t(cols_ - 1)) return false;
  const size_t n = point_count();
  layout.surface_points = n;
  layout.walls.clear();
  if (std::none_of(cells.begin(), cells.end(), [](std::uint8_t c) { return c != 0; })) {
    layout.triangles.assign(triangles_.begin(), triangles_.end());
    return true;
  }
  const int res = def_.resolution, r1 = res + 1;
  const size_t quads = triangle_cell_.size() / 2;
  std::vector<std::uint8_t> dropped(quads);
  for (size_t q = 0; q < quads; ++q) dropped[q] = cells[size_t(triangle_cell_[2 * q])] != 0;
  layout.triangles.clear();
  for (size_t q = 0; q < quads; ++q)
    if (!dropped[q])
      layout.triangles.insert(layout.triangles.end(), triangles_.begin() + 6 * q, triangles_.begin() + 6 * q + 6);
  // A kept quad's side against a dropped one (in its patch or the next) gets a wall: four points
  // after the surface's, slots (top p, top q, bottom p, bottom q) as cut_walls fills them.
  const int pc = patch_cols_, pr = patch_rows_;
  for (int pi = 0; pi < pr; ++pi)
    for (int pj = 0; pj < pc; ++pj)
      for (int a = 0; a < res; ++a)
        for (int b = 0; b < res; ++b) {
          const size_t q = (size_t(pi) * pc + pj) * size_t(res) * res + size_t(a) * res + b;
          if (dropped[q]) continue;
          const uint32_t base = uint32_t((size_t(pi) * pc + pj) * size_t(r1) * r1);
          const uint32_t p00 = base + uint32_t(a * r1 + b), p01 = p00 + 1, p10 = p00 + uint32_t(r1), p11 = p10 + 1;
          struct Side { int da, db; uint32_t p, q; };
          const Side sides[4] = {{-1, 0, p00, p01}, {1, 0, p10, p11}, {0, -1, p00, p10}, {0, 1, p01, p11}};
          for (const Side& sd : sides) {
            int na = a + sd.da, nb = b + sd.db, npi = pi, npj = pj;
            if (na < 0) na += res, --npi;
            if (na >= res) na -= res, ++npi;
            if (nb < 0) nb += res, --npj;
            if (nb >= res) nb -= res, ++npj;
            if (npi < 0 || npj < 0 || npi >= pr || npj >= pc) continue;
            if (!dropped[(size_t(npi) * pc + npj) * size_t(res) * res + size_t(na) * res + nb]) continue;
            const uint32_t w = uint32_t(n + 4 * layout.walls.size());
            layout.walls.push_back({sd.p, sd.q, p00, p01, p10, p11});
            layout.triangles.insert(layout.triangles.end(), {w, w + 1, w + 3, w, w + 3, w + 2});
          }
        }
  return true;
}

bool SurfaceTessellator::cut_walls(const SurfaceCutLayout& layout, float thickness, std::span<float> positions,
                                   std::span<float> normals) const noexcept {
  const size_t n = point_count();
  if (layout.surface_points != n || positions.size() != 3 * layout.point_count() || normals.size() != positions.size())
    return false;
  const auto pos = [&](uint32_t i) { return Vec3f(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); };
  const auto nrm = [&](uint32_t i) { return Vec3f(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]); };
  const auto put = [&](size_t slot, const Vec3f& p, const Vec3f& w) {
    for (int k = 0; k < 3; ++k) positions[3 * slot + size_t(k)] = p[k], normals[3 * slot + size_t(k)] = w[k];
  };
  for (size_t k = 0; k < layout.walls.size(); ++k) {
    const auto& wall = layout.walls[k];
    const Vec3f P = pos(wall[0]), Q = pos(wall[1]), nP = nrm(wall[0]), nQ = nrm(wall[1]);
    const Vec3f centre = 0.25f * (pos(wall[2]) + pos(wall[3]) + pos(wall[4]) + pos(wall[5]));
    // The wall faces into the wound: from the quad's centre across the side, in the surface's plane.
    Vec3f w = 0.5f * (P + Q) - centre;
    const Vec3f nm = (nP + nQ).normalized();
    w -= w.dot(nm) * nm;
    const size_t slot = n + 4 * k;
    if (!(w.squaredNorm() > 0)) {  // a collapsed quad: no side to stand a wall on (zero-area triangles)
      for (size_t s = 0; s < 4; ++s) put(slot + s, P, nm);
      continue;
    }
    w.normalize();
    const Vec3f bP = P - thickness * nP, bQ = Q - thickness * nQ;
    // The layout's triangles are fixed (slots 0 1 3, 0 3 2); cut() winds a wall as (top p, top q,
    // bottom q) or the other way, by this sign: the other way is the same two triangles with
    // slots 1 and 2 swapped.
    const bool ccw = (Q - P).cross(bQ - P).dot(w) > 0;
    put(slot, P, w);
    put(slot + 1, ccw ? Q : bP, w);
    put(slot + 2, ccw ? bP : Q, w);
    put(slot + 3, bQ, w);
  }
  return true;
}

size_t SurfaceTessellator::point_count() const {
  const size_t r1 = size_t(def_.resolution) + 1;
  return size_t(patch_rows_) * size_t(patch_cols_) * r1 * r1;
}

bool SurfaceTessellator::smooth_border_normals(std::span<float> normals) const noexcept {
  if (normals.size() != point_count() * 3) return false;
  const size_t R = size_t(def_.resolution) + 1, per_patch = R * R;
  const size_t pc = size_t(patch_cols_), pr = size_t(patch_rows_);
  const auto average = [&](size_t a, size_t b) {
    float* na = &normals[3 * a];
    float* nb = &normals[3 * b];
    float m[3] = {na[0] + nb[0], na[1] + nb[1], na[2] + nb[2]};
    const float len = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
    if (!(len > 1e-12f)) return;  // opposite normals (a fold): leave both
    for (int k = 0; k < 3; ++k) na[k] = nb[k] = m[k] / len;
  };
  // Across the patches' left/right borders (u = 1 of (i, j) against u = 0 of (i, j+1)), then their
  // top/bottom ones: a corner shared by four patches ends with the mean of all four.
  for (size_t i = 0; i < pr; ++i)
    for (size_t j = 0; j + 1 < pc; ++j) {
      const size_t left = (i * pc + j) * per_patch, right = (i * pc + j + 1) * per_patch;
      for (size_t a = 0; a < R; ++a) average(left + a * R + (R - 1), right + a * R);
    }
  for (size_t i = 0; i + 1 < pr; ++i)
    for (size_t j = 0; j < pc; ++j) {
      const size_t up = (i * pc + j) * per_patch, down = ((i + 1) * pc + j) * per_patch;
      for (size_t b = 0; b < R; ++b) average(up + (R - 1) * R + b, down + b);
    }
  return true;
}

bool straighten_grid_ends(std::span<Vec3f> control, int rows, int cols) noexcept {
  if (rows < 3 || cols < 2 || control.size() != size_t(rows) * size_t(cols)) return false;
  const auto at = [&](int r, int c) -> Vec3f& { return control[size_t(r) * size_t(cols) + size_t(c)]; };
  // Decide every row from the grid as it came (a moved end must not move its neighbours'), then move.
  for (int end = 0; end < 2; ++end) {
    const int c0 = end == 0 ? 0 : cols - 1, c1 = end == 0 ? 1 : cols - 2;
    float shift = 0;  // the previous row's move, applied one row late (after this row's decision)
    for (int r = 0; r < rows; ++r) {
      const Vec3f step = at(r, c0) - at(r, c1);  // outward along the row
      const float len2 = step.squaredNorm();
      float d = 0;
      if (len2 > 0) {
        const Vec3f others = r == 0 ? at(1, c0) : r == rows - 1 ? at(rows - 2, c0) : 0.5f * (at(r - 1, c0) + at(r + 1, c0));
        d = (others - at(r, c0)).dot(step) / len2;  // > 0: this end lies inward of the others
      }
      if (r > 0 && shift > 0) at(r - 1, c0) += shift * (at(r - 1, c0) - at(r - 1, c1));
      shift = d > 0.25f && d < 2.0f ? d : 0.0f;
    }
    if (shift > 0) at(rows - 1, c0) += shift * (at(rows - 1, c0) - at(rows - 1, c1));
  }
  return true;
}

std::array<int, 4> SurfaceTessellator::patch_rows_of(int patch_i) const { return v_.index.at(patch_i); }
std::array<int, 4> SurfaceTessellator::patch_cols_of(int patch_j) const { return u_.index.at(patch_j); }

// --- per frame -----------------------------------------------------------------------------------

bool SurfaceTessellator::tessellate(std::span<const Vec3f> control, SurfaceBuffers& out) const {
  if (control.size() != size_t(rows_) * size_t(cols_)) return false;
  const size_t n = point_count();
  // A cut() since changed the triangles (fewer) or added wall points (more points): start afresh.
  if (out.triangles.size() != triangles_.size() || out.positions.size() != 3 * n) out.triangles = triangles_;
  if (out.positions.size() != 3 * n) out.positions.resize(3 * n);
  if (out.normals.size() != 3 * n) out.normals.resize(3 * n);
  return tessellate(control, out.positions, out.normals);
}

bool SurfaceTessellator::tessellate(std::span<const Vec3f> control, std::span<float> positions,
                                    std::span<float> normals) const noexcept {
  const size_t n = point_count();
  if (control.size() != size_t(rows_) * size_t(cols_) || positions.size() != 3 * n || normals.size() != 3 * n)
    return false;
  const size_t per_patch = 3 * (size_t(def_.resolution) + 1) * (size_t(def_.resolution) + 1);
  for (int i = 0; i < patch_rows_; ++i)
    for (int j = 0; j < patch_cols_; ++j) {
      const size_t offset = (size_t(i) * patch_cols_ + j) * per_patch;
      tessellate_patch(control, i, j, positions.data() + offset, normals.data() + offset);
    }
  return true;
}

// One patch: S(u,v) = Σ_a Σ_b W_a(v) W_b(u) G_ab with W the slot weights (Bernstein or B-spline
// basis folded with the boundary combinations), evaluated separably: first the 4 column curves
// Q_b(v) = Σ_a W_a(v) G_ab and Q'_b(v) = Σ_a W'_a(v) G_ab once per v sample, then per point
// S = Σ_b W_b(u) Q_b, ∂S/∂u = Σ_b W'_b(u) Q_b, ∂S/∂v = Σ_b W_b(u) Q'_b (36 multiply-adds), in
// structure-of-arrays rows so the compiler vectorises over u.
void SurfaceTessellator::tessellate_patch(std::span<const Vec3f> control, int i, int j, float* positions,
                                          float* normals) const noexcept {
  const int r1 = def_.resolution + 1;
  const std::array<int, 4>& ri = v_.index[i];
  const std::array<int, 4>& ci = u_.index[j];
  float g[3][4][4];  // [xyz][slot along v][slot along u]
  const Vec3f& g00 = control[size_t(ri[0]) * cols_ + ci[0]];
  float extent2 = 0;  // squared size of the patch's control net, m²: the scale of "vanishing"
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const Vec3f& p = control[size_t(ri[a]) * cols_ + ci[b]];
      g[0][a][b] = p.x(), g[1][a][b] = p.y(), g[2][a][b] = p.z();
      extent2 = std::max(extent2, (p - g00).squaredNorm());
    }
  // A derivative shorter than 1e-6 of the patch's size, or than 1e-5 of its distance from the
  // origin (float rounding of the coordinates), is noise, not a direction.
  const float tiny2 = 1e-12f * extent2 + 1e-10f * g00.squaredNorm();
  const float* wv = &v_.w[size_t(i) * 4 * r1];
  const float* dwv = &v_.dw[size_t(i) * 4 * r1];
  const float* wu = &u_.w[size_t(j) * 4 * r1];
  const float* dwu = &u_.dw[size_t(j) * 4 * r1];

  // A row of samples at a time, in chunks of structure-of-arrays stack scratch (no allocation):
  // plain loops the compiler vectorises, the square roots in scale_rows_by_inverse_norm.
  alignas(16) float px[kChunk], py[kChunk], pz[kChunk], cx[kChunk], cy[kChunk], cz[kChunk], inv[kChunk];
  alignas(16) float c2[kChunk], ok[kChunk];
  int degenerate = 0;
  for (int a = 0; a < r1; ++a) {
    float q[3][4], qv[3][4];
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 4; ++b) {
        q[c][b] = wv[0 * r1 + a] * g[c][0][b] + wv[1 * r1 + a] * g[c][1][b] + wv[2 * r1 + a] * g[c][2][b] +
                  wv[3 * r1 + a] * g[c][3][b];
        qv[c][b] = dwv[0 * r1 + a] * g[c][0][b] + dwv[1 * r1 + a] * g[c][1][b] +
                   dwv[2 * r1 + a] * g[c][2][b] + dwv[3 * r1 + a] * g[c][3][b];
      }
    float* pr = positions + size_t(a) * r1 * 3;
    float* nr = normals + size_t(a) * r1 * 3;
    for (int b0 = 0; b0 < r1; b0 += kChunk) {
      const int n = std::min(kChunk, r1 - b0);
      const float* w0 = wu + b0;
      const float* w1 = wu + r1 + b0;
      const float* w2 = wu + 2 * r1 + b0;
      const float* w3 = wu + 3 * r1 + b0;
      const float* d0 = dwu + b0;
      const float* d1 = dwu + r1 + b0;
      const float* d2 = dwu + 2 * r1 + b0;
      const float* d3 = dwu + 3 * r1 + b0;
      for (int b = 0; b < n; ++b) {
        px[b] = w0[b] * q[0][0] + w1[b] * q[0][1] + w2[b] * q[0][2] + w3[b] * q[0][3];
        py[b] = w0[b] * q[1][0] + w1[b] * q[1][1] + w2[b] * q[1][2] + w3[b] * q[1][3];
        pz[b] = w0[b] * q[2][0] + w1[b] * q[2][1] + w2[b] * q[2][2] + w3[b] * q[2][3];
        const float sux = d0[b] * q[0][0] + d1[b] * q[0][1] + d2[b] * q[0][2] + d3[b] * q[0][3];
        const float suy = d0[b] * q[1][0] + d1[b] * q[1][1] + d2[b] * q[1][2] + d3[b] * q[1][3];
        const float suz = d0[b] * q[2][0] + d1[b] * q[2][1] + d2[b] * q[2][2] + d3[b] * q[2][3];
        const float svx = w0[b] * qv[0][0] + w1[b] * qv[0][1] + w2[b] * qv[0][2] + w3[b] * qv[0][3];
        const float svy = w0[b] * qv[1][0] + w1[b] * qv[1][1] + w2[b] * qv[1][2] + w3[b] * qv[1][3];
        const float svz = w0[b] * qv[2][0] + w1[b] * qv[2][1] + w2[b] * qv[2][2] + w3[b] * qv[2][3];
        cx[b] = suy * svz - suz * svy;
        cy[b] = suz * svx - sux * svz;
        cz[b] = sux * svy - suy * svx;
        c2[b] = cx[b] * cx[b] + cy[b] * cy[b] + cz[b] * cz[b];
        const float su2 = sux * sux + suy * suy + suz * suz;
        const float sv2 = svx * svx + svy * svy + svz * svz;
        // Degenerate when |du × dv| ≤ 1e-6 |du||dv| (parallel derivatives) or either is noise.
        ok[b] = ((c2[b] > 1e-12f * su2 * sv2) & (su2 > tiny2) & (sv2 > tiny2)) ? 1.0f : 0.0f;
      }
      degenerate += inverse_norms(c2, ok, inv, n);
      for (int b = 0; b < n; ++b) {
        float* po = pr + 3 * (b0 + b);
        float* no = nr + 3 * (b0 + b);
        po[0] = px[b], po[1] = py[b], po[2] = pz[b];
        no[0] = cx[b] * inv[b], no[1] = cy[b] * inv[b], no[2] = cz[b] * inv[b];
      }
    }
  }
  if (degenerate == 0) return;

  // Fallback where the analytic normal is undefined: from the neighbouring samples' positions,
  // then the patch's corner diagonals, then +y.
  auto at = [&](int a, int b) {
    const float* p = positions + (size_t(a) * r1 + b) * 3;
    return Vec3f(p[0], p[1], p[2]);
  };
  const int res = def_.resolution;
  const Vec3f d2 = at(0, res) - at(res, 0), d1 = at(res, res) - at(0, 0);
  Vec3f diag = d2.cross(d1);  // (u − v) × (u + v) = 2 u × v: along du × dv
  const bool diag_ok = d1.squaredNorm() > tiny2 && d2.squaredNorm() > tiny2 &&
                       diag.squaredNorm() > 1e-12f * d1.squaredNorm() * d2.squaredNorm();
  diag = diag_ok ? diag.normalized() : Vec3f::UnitY();
  for (int a = 0; a < r1; ++a)
    for (int b = 0; b < r1; ++b) {
      float* nr = normals + (size_t(a) * r1 + b) * 3;
      if (nr[0] != 0.0f || nr[1] != 0.0f || nr[2] != 0.0f) continue;
      const Vec3f du = at(a, std::min(b + 1, res)) - at(a, std::max(b - 1, 0));
      const Vec3f dv = at(std::min(a + 1, res), b) - at(std::max(a - 1, 0), b);
      Vec3f nn = du.cross(dv);
      const bool nn_ok = du.squaredNorm() > tiny2 && dv.squaredNorm() > tiny2 &&
                         nn.squaredNorm() > 1e-12f * du.squaredNorm() * dv.squaredNorm();
      nn = nn_ok ? nn.normalized() : diag;
      nr[0] = nn.x(), nr[1] = nn.y(), nr[2] = nn.z();
    }
}

SurfacePoint SurfaceTessellator::evaluate(std::span<const Vec3f> control, int patch_i, int patch_j, float u,
                                          float v) const {
  assert(control.size() == size_t(rows_) * size_t(cols_));
  assert(patch_i >= 0 && patch_i < patch_rows_ && patch_j >= 0 && patch_j < patch_cols_);
  const Cubic cu = cubic_basis(def_.scheme, u), cv = cubic_basis(def_.scheme, v);
  // Slot weights from the cubic basis: W_a(t) = Σ_k coef[a][k] B_k(t), and derivatives.
  auto slot = [](const std::array<std::array<float, 4>, 4>& coef, const std::array<float, 4>& basis) {
    std::array<float, 4> w{};
    for (int a = 0; a < 4; ++a)
      for (int k = 0; k < 4; ++k) w[a] += coef[a][k] * basis[k];
    return w;
  };
  const auto& coef_u = u_.coef[patch_j];
  const auto& coef_v = v_.coef[patch_i];
  const auto wu = slot(coef_u, cu.b), du = slot(coef_u, cu.d1), duu = slot(coef_u, cu.d2);
  const auto wv = slot(coef_v, cv.b), dv = slot(coef_v, cv.d1), dvv = slot(coef_v, cv.d2);
  SurfacePoint sp;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const Vec3f& p = control[size_t(v_.index[patch_i][a]) * cols_ + u_.index[patch_j][b]];
      sp.position += wv[a] * wu[b] * p;
      sp.du += wv[a] * du[b] * p;
      sp.dv += dv[a] * wu[b] * p;
      sp.duu += wv[a] * duu[b] * p;
      sp.duv += dv[a] * du[b] * p;
      sp.dvv += dvv[a] * wu[b] * p;
    }
  const Vec3f n = sp.du.cross(sp.dv);
  if (n.squaredNorm() > 1e-12f * sp.du.squaredNorm() * sp.dv.squaredNorm() && n.squaredNorm() > 0)
    sp.normal = n.normalized();
  return sp;
}

Result<GridDrawing> GridDrawing::build(int rows, int cols, const SurfaceDef& def) {
  auto t = SurfaceTessellator::build(rows, cols, def);
  if (!t) return t.error();
  GridDrawing d(std::move(*t));
  const size_t n = d.tess_.point_count();
  d.out_.positions.resize(3 * n), d.out_.normals.resize(3 * n);
  d.control_.reserve(size_t(rows) * size_t(cols));
  d.cells_.resize(size_t(rows - 1) * size_t(cols - 1));
  d.tess_.cut_layout(d.cells_, d.layout_);  // nothing cut: the whole surface
  return d;
}

bool GridDrawing::draw(std::span<const Vec3f> points, std::span<const std::array<int, 2>> cut_links, float thickness) {
  const int rows = tess_.rows(), cols = tess_.cols();
  if (points.size() != size_t(rows) * size_t(cols)) return false;
  if (!std::equal(cut_links.begin(), cut_links.end(), cut_links_.begin(), cut_links_.end())) {
    // The cut changed (a cut stays cut, so it grew, or the layer healed): lay it out again.
    if (!grid_cut_cells(rows, cols, cut_links, cells_) || !tess_.cut_layout(cells_, layout_)) return false;
    cut_links_.assign(cut_links.begin(), cut_links.end());
    out_.positions.resize(3 * layout_.point_count()), out_.normals.resize(3 * layout_.point_count());
    ++revision_;
  }
  control_.assign(points.begin(), points.end());
  straighten_grid_ends(control_, rows, cols);
  const size_t n = 3 * tess_.point_count();
  const std::span<float> positions(out_.positions), normals(out_.normals);
  return tess_.tessellate(control_, positions.first(n), normals.first(n)) &&
         tess_.smooth_border_normals(normals.first(n)) && tess_.cut_walls(layout_, thickness, positions, normals);
}

SurfaceBuffers GridDrawing::take() && {
  out_.triangles = std::move(layout_.triangles);
  return std::move(out_);
}

Result<SurfaceBuffers> tessellate_grid(std::span<const Vec3f> control, int rows, int cols,
                                       const SurfaceDef& def) {
  auto t = SurfaceTessellator::build(rows, cols, def);
  if (!t) return t.error();
  if (control.size() != size_t(std::max(rows, 0)) * size_t(std::max(cols, 0)))
    return Error{"surface: " + std::to_string(control.size()) + " control points for a " + std::to_string(rows) +
                 " x " + std::to_string(cols) + " grid; expected " + std::to_string(rows * cols)};
  SurfaceBuffers out;
  if (!t->tessellate(control, out)) return Error{"surface: tessellation failed"};
  return out;
}

}  // namespace palpate
