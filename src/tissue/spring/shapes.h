// shapes.h — meshes made in code for the mass-spring model: a regular tetrahedralised block, a flat
// sheet, and the boundary of a tet mesh (internal; shared by the tissue, tests and benchmarks).
#pragma once

#include <palpate/mesh.h>
#include <palpate/scene_def.h>

#include <array>
#include <vector>

namespace palpate::spring {

// nx x ny x nz vertices on a grid of `spacing` (m) starting at `origin`; each cube cut into five
// tetrahedra, alternating with the cube's parity so that neighbouring cubes share face diagonals
// (10³ vertices → 5,130 edges; 20³ → 44,460). Vertex (i, j, k) has index i + nx (j + ny k).
TetMesh make_block(int nx, int ny, int nz, double spacing, const Vec3& origin = Vec3::Zero());
// The same five-tet block over given grid lines (each increasing, at least two): e.g. a grid graded
// toward an indenter with graded_coordinates.
TetMesh make_block(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<double>& zs);

// Grid lines from `from` to `to`: spacing about `fine` over [fine_from, fine_to] (inside [from, to]),
// then cells growing by `ratio` per cell away from it, capped at `coarse`; each graded side is
// stretched evenly so that it ends exactly at `from` / `to`.
std::vector<double> graded_coordinates(double from, double to, double fine_from, double fine_to, double fine,
                                       double coarse, double ratio);

// A flat sheet of triangles over a grid in the plane through patch.center normal to patch.normal.
SurfaceMesh make_sheet(const PatchDef& patch);

// The triangles of a tet mesh's boundary, outward oriented, over the same vertex indices.
std::vector<std::array<int, 3>> boundary_triangles(const TetMesh& mesh);

// A ball of radius r cut out of a make_block grid of `spacing`: the tets whose centroid lies inside,
// vertices renumbered compactly. An organ-like tet mesh with an irregular boundary.
TetMesh make_tet_ball(double radius, double spacing);

// The tets of a make_block grid (of `spacing`, its lines on the multiples of spacing) over [lo, hi]
// whose centroid `inside(centroid, context)` accepts, vertices renumbered compactly (first use first).
TetMesh tet_region(const Vec3& lo, const Vec3& hi, double spacing, bool (*inside)(const Vec3&, const void*),
                   const void* context);

// A gallbladder in its fossa on the liver's underside (data/scenes/gallbladder.yaml; the figures and
// their sources in docs/models/cutting.md): a pear-shaped body 80 mm long (x: neck at −x, fundus at +x),
// 30 mm broad (z) and 27 mm deep (y), its upper quarter sunk into a slab of liver 20 mm thick whose
// underside is the plane y = 0 and whose edge (x = 28 mm) the fundus passes, as it does below the
// liver's inferior border. Tets of a grid of `spacing` through the origin; `held`: the liver's top
// face (its ligaments and the diaphragm above hold it). The attachment — the gallbladder's bed — is
// the grid's springs across y = 0 over the gallbladder's footprint: what a dissection divides.
struct GallbladderBed {
  TetMesh mesh;
  std::vector<int> held;
};
GallbladderBed make_gallbladder_bed(double spacing, const Vec3& offset = Vec3::Zero());

// A UV-sphere-like closed surface ("organ" stand-in) with about `vertices` vertices, radius r.
SurfaceMesh make_ball_surface(int vertices, double radius);

}  // namespace palpate::spring
