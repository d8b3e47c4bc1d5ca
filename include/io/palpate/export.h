// palpate/export.h — a run's state written for other tools: VTK XML unstructured grids (.vtu,
// binary appended, float64) with a ParaView collection (.pvd) of their times, and an animated
// glTF 2.0 scene (.glb). Plain arrays in, files out: the simulation layer turns a run's snapshots
// into these (palpate/run.h, RunOptions::exports); docs/export.md says what each file holds.
#pragma once

#include <palpate/core.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace palpate {

// VTK's cell types used here.
inline constexpr std::uint8_t kVtkVertex = 1, kVtkLine = 3, kVtkTriangle = 5, kVtkTetra = 10;

// One point or cell array: `components` values per point, float64 (or Int32 when `integer`).
struct ExportArray {
  std::string name;
  int components = 1;
  bool integer = false;
  std::vector<double> values;  // (points x components)
};

// One unstructured grid: points, cells (each a VTK type and its point indices), point data, and
// field data (one tuple each: the frame's time, the tool's force, ...).
struct ExportGrid {
  std::vector<double> points;            // (n x 3) m
  std::vector<std::int64_t> connectivity;
  std::vector<std::int64_t> offsets;     // the end of each cell in connectivity
  std::vector<std::uint8_t> types;       // each cell's VTK type
  std::vector<ExportArray> point_data;
  std::vector<ExportArray> field_data;
  size_t point_count() const { return points.size() / 3; }
  void add_cell(std::uint8_t type, std::span<const std::int64_t> ids);
};

// Writes `grid` as a VTK XML UnstructuredGrid, binary appended raw (UInt64 headers, little-endian),
// atomically. The error names the file.
Status write_vtu(const std::filesystem::path& file, const ExportGrid& grid);

// One dataset of a ParaView collection: its time (s), its part (0, 1, ...: one per tissue and the
// tools) and its file relative to the .pvd.
struct PvdDataSet {
  double time = 0;
  int part = 0;
  std::string name;  // the part's name (a tissue's, "tools")
  std::string file;
};
Status write_pvd(const std::filesystem::path& file, std::span<const PvdDataSet> sets);

// An animated glTF 2.0 scene: surfaces whose points move (one morph target per frame, played by
// a "weights" animation), and rigid tools (translation and rotation channels), at the same times.
class GltfScene {
 public:
  GltfScene();
  ~GltfScene();
  GltfScene(const GltfScene&) = delete;
  GltfScene& operator=(const GltfScene&) = delete;
  // A surface with a fixed triangulation; `rgba` its colour. Returns its index.
  int add_surface(const std::string& name, std::span<const std::uint32_t> triangles, std::array<float, 4> rgba);
  // A rigid tool: "needle" (a cylinder of `radius` and `length` from its tip back along `axis`, in
  // its own frame: tip at the origin), "blade" (a scalpel: its cutting edge of `length` from the tip
  // back along `axis`, the flat blade `2·radius` thick behind it and a handle beyond the heel),
  // "sphere" (of `radius`) or "box" (half extents `size`).
  int add_tool(const std::string& name, const std::string& shape, double radius, double length, const Vec3& axis,
               const Vec3& size, std::array<float, 4> rgba);
  // One frame at `time` (s, ascending): each surface's points (n x 3, the same n every frame) and
  // each tool's pose. Call with every surface and tool, in the order added.
  void add_frame(double time, std::span<const std::vector<float>> surface_points, std::span<const Vec3> tool_positions,
                 std::span<const Quat> tool_orientations);
  size_t frame_count() const;
  // Writes the scene as one binary .glb (atomically). The error names the file.
  Status write_glb(const std::filesystem::path& file) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palpate
