// tissue_view.cpp — a tissue's drawn surface from its snapshot: the grid's (GridDrawing, with its
// wound) or the mesh's PN triangles, and the control net without the cut links.
#include "tissue_view.h"

#include <palpate/render.h>

#include <algorithm>

namespace palpate::view {
namespace {

// Area-weighted vertex normals of a triangle mesh (a zero normal where no triangle touches).
void vertex_normals(const TissueSnapshot& s, std::vector<Vec3f>& out) {
  out.assign(s.points.size(), Vec3f::Zero());
  const auto n = static_cast<int>(s.points.size());
  for (const auto& t : s.triangles) {
    if (t[0] < 0 || t[1] < 0 || t[2] < 0 || t[0] >= n || t[1] >= n || t[2] >= n) continue;
    const Vec3f& a = s.points[static_cast<size_t>(t[0])];
    const Vec3f face =
        (s.points[static_cast<size_t>(t[1])] - a).cross(s.points[static_cast<size_t>(t[2])] - a);
    for (int k : t) out[static_cast<size_t>(k)] += face;
  }
}

// The control net (grid_lines: each control point joined to its right and lower neighbours),
// less the segments that are cut links: the net would draw a thread across the wound.
void net_without_cuts(TissueView& view, std::span<const std::array<int, 2>> cut_links) {
  std::vector<std::array<int, 2>> cut;
  cut.reserve(cut_links.size());
  for (const auto& [i, j] : cut_links) cut.push_back({std::min(i, j), std::max(i, j)});
  std::sort(cut.begin(), cut.end());
  view.grid_links = grid_lines(view.rows, view.cols);
  std::erase_if(view.grid_links, [&](const std::array<int, 2>& s) {
    return std::binary_search(cut.begin(), cut.end(), s);
  });
}

}  // namespace

bool update_view(TissueView& view, const TissueSnapshot& s, int resolution, float wound_depth) {
  const size_t n = s.points.size();
  if (s.rows_cols.size() == 2 && s.rows_cols[0] >= 2 && s.rows_cols[1] >= 2 &&
      static_cast<size_t>(s.rows_cols[0]) * static_cast<size_t>(s.rows_cols[1]) == n) {
    if (!view.grid || view.rows != s.rows_cols[0] || view.cols != s.rows_cols[1]) {
      SurfaceDef def;
      def.scheme = SurfaceScheme::bezier;
      def.resolution = resolution;
      auto built = GridDrawing::build(s.rows_cols[0], s.rows_cols[1], def);
      if (!built) return false;
      view.grid.emplace(std::move(*built));
      view.pn.reset();
      view.rows = s.rows_cols[0];
      view.cols = s.rows_cols[1];
      net_without_cuts(view, {});
      view.grid_links_layout = view.grid->layout_revision();
    }
    // Drawn as the run's frames draw it: the ends straightened, the border normals shared, and
    // the wound cut open (laid out again only when the cut links changed).
    const bool drawn = view.grid->draw(s.points, s.cut_links, wound_depth);
    if (view.grid_links_layout != view.grid->layout_revision()) {
      net_without_cuts(view, view.grid->cut_links());
      view.grid_links_layout = view.grid->layout_revision();
    }
    return drawn;
  }
  view.grid.reset();
  view.rows = view.cols = 0;
  view.grid_links.clear();
  if (s.triangles.empty()) {
    view.pn.reset();
    return false;
  }
  if (!view.pn || view.pn->vertex_count() != static_cast<int>(n) ||
      view.mesh_triangles != s.triangles.size()) {
    auto built = PnTessellator::build(static_cast<int>(n), s.triangles, 3);
    if (!built) {
      view.pn.reset();
      return false;
    }
    view.pn.emplace(std::move(*built));
    view.mesh_triangles = s.triangles.size();
    view.pn_positions.resize(view.pn->point_count() * 3);
    view.pn_normals.resize(view.pn->point_count() * 3);
  }
  vertex_normals(s, view.vertex_normals);
  return view.pn->tessellate(s.points, view.vertex_normals, view.pn_positions, view.pn_normals);
}

}  // namespace palpate::view
