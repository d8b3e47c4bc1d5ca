// tissue_view.h — what the viewer draws of one tissue, brought up to date from its snapshot each
// frame: a grid's Bézier surface (with a cut layer's wound, as the run's frames draw it) or a
// mesh's PN triangles, and the control net. Plain arrays: no OpenGL, no window.
#pragma once

#include <palpate/surface.h>
#include <palpate/tissue.h>

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace palpate::view {

// The tessellators are built when the grid or mesh changes size (rarely), then reused
// allocation-free. A grid's wound is laid out again (new triangles, the net without its cut
// segments) only when the snapshot's cut links change.
struct TissueView {
  std::optional<GridDrawing> grid;  // rows_cols snapshots: Bézier patches over the particles
  std::optional<PnTessellator> pn;  // triangle snapshots: PN triangles over the mesh
  size_t mesh_triangles = 0;        // triangle count the PN tessellator was built for
  std::vector<float> pn_positions, pn_normals;  // (#P x 3) the PN surface, m and unit
  std::vector<Vec3f> vertex_normals;            // (#points) area-weighted, PN input
  std::vector<std::array<int, 2>> grid_links;   // the control net's segments, less the cut links
  std::uint64_t grid_links_layout = 0;  // the grid's layout_revision() grid_links were made for
  int rows = 0, cols = 0;

  // The drawn surface: (#P x 3) positions (m), normals (unit) and (#T x 3) triangles.
  std::span<const float> positions() const {
    if (grid) return grid->positions();
    return pn_positions;
  }
  std::span<const float> normals() const {
    if (grid) return grid->normals();
    return pn_normals;
  }
  std::span<const std::uint32_t> triangles() const {
    if (grid) return grid->triangles();
    if (pn) return pn->triangles();
    return {};
  }
};

// Bring `view` up to date with snapshot `s` (Bézier segments per patch edge `resolution`; a cut
// layer's walls `wound_depth` m deep); false when it has nothing to draw as a surface.
bool update_view(TissueView& view, const TissueSnapshot& s, int resolution, float wound_depth);

}  // namespace palpate::view
