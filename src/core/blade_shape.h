// blade_shape.h — what a blade tool looks like, as triangles: the flat blade on its cutting edge and
// the handle behind it, shared by the headless renderer, the viewer and the glTF export so all three
// draw the same scalpel. Drawing only (built per frame, never on the haptic path).
#pragma once

#include <palpate/core.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace palpate {

// The blade's dimensions from the tool's: the cutting edge runs from the heel (tip − length·axis)
// to the tip; the blade's back lies `depth` from the edge along `back`, its faces `thickness` apart
// (twice the tool's radius, the thickness the tissue feels); the handle continues from the heel
// back along −axis. The shape of a No. 10–15 scalpel: a blade about a third as deep as it is long.
struct BladeShape {
  Vec3 tip = Vec3::Zero();       // m
  Vec3 axis = Vec3(0, -1, 0);    // unit, heel → tip along the edge
  Vec3 back = Vec3(-1, 0, 0);    // unit, ⟂ axis: from the edge towards the blade's back (blade_back)
  double length = 0.02;          // m, the cutting edge
  double depth = 0.006;          // m, edge to back
  double thickness = 0.0004;     // m, between the blade's faces
  double handle_length = 0.06;   // m, behind the heel
  double handle_width = 0.006;   // m, along `back`
  double handle_thickness = 0.002;  // m
  Vec3 heel() const { return tip - length * axis; }
};

// The blade's back direction for an edge along `axis` (unit): up (+y) made perpendicular to the edge,
// so a blade held over tissue below has its edge down and its back up; for an edge within about 2°
// of vertical, the edge × z. The edge is a segment to the tissue, so its roll about itself does not
// cut: the drawing fixes it by this rule.
inline Vec3 blade_back(const Vec3& axis) noexcept {
  const Vec3 up = Vec3::UnitY() - axis.y() * axis;
  if (up.norm() > 0.04) return up.normalized();
  return axis.cross(Vec3::UnitZ()).normalized();
}

// The shape of a blade tool of edge `length` (m) and half thickness `radius` (m) at `tip` along
// `axis` (any length but zero).
inline BladeShape blade_shape(const Vec3& tip, const Vec3& axis, double length, double radius) noexcept {
  BladeShape s;
  s.tip = tip;
  s.axis = axis.normalized();
  s.back = blade_back(s.axis);
  s.length = length;
  s.depth = std::clamp(0.32 * length, 0.001, 0.012);
  s.thickness = 2 * radius;
  s.handle_width = std::max(s.depth, 0.004);
  s.handle_thickness = std::max(2.5 * s.thickness, 0.002);
  return s;
}

// Flat-shaded triangles (outward normals), appended.
struct BladeMesh {
  std::vector<float> positions, normals;  // (#P x 3) m, unit
  std::vector<std::uint32_t> triangles;   // (#T x 3)
};

namespace blade_detail {
inline void add_quad(BladeMesh& m, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& outward) {
  Vec3 n = (b - a).cross(c - a);
  if (!(n.norm() > 0)) n = outward;
  n.normalize();
  if (n.dot(outward) < 0) n = -n;
  const auto base = static_cast<std::uint32_t>(m.positions.size() / 3);
  for (const Vec3* p : {&a, &b, &c, &d}) {
    m.positions.insert(m.positions.end(), {float(p->x()), float(p->y()), float(p->z())});
    m.normals.insert(m.normals.end(), {float(n.x()), float(n.y()), float(n.z())});
  }
  m.triangles.insert(m.triangles.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// A prism over a convex outline `o` (points in the plane through them, in order) of thickness 2h
// along `side` (unit, ⟂ the outline's plane): two faces and the walls.
inline void add_prism(BladeMesh& m, const std::vector<Vec3>& o, const Vec3& side, double h) {
  const size_t n = o.size();
  Vec3 centre = Vec3::Zero();
  for (const Vec3& p : o) centre += p;
  centre /= double(n);
  for (int s : {-1, 1}) {
    const Vec3 off = double(s) * h * side;
    for (size_t i = 1; i + 1 < n; ++i)  // a fan; each triangle as a degenerate quad keeps one helper
      add_quad(m, o[0] + off, o[i] + off, o[i + 1] + off, o[i + 1] + off, double(s) * side);
  }
  for (size_t i = 0; i < n; ++i) {
    const Vec3 &a = o[i], &b = o[(i + 1) % n];
    const Vec3 mid = 0.5 * (a + b);
    add_quad(m, a - h * side, b - h * side, b + h * side, a + h * side, mid - centre);
  }
}
}  // namespace blade_detail

// The blade: its outline heel → tip along the edge, then the back sweeping down to the point (a
// scalpel's belly-less profile), between two faces `thickness` apart.
inline void append_blade(BladeMesh& m, const BladeShape& s) {
  const Vec3 heel = s.heel(), side = s.axis.cross(s.back).normalized();
  const std::vector<Vec3> outline = {heel, s.tip, heel + 0.7 * s.length * s.axis + s.depth * s.back,
                                     heel + s.depth * s.back};
  blade_detail::add_prism(m, outline, side, 0.5 * s.thickness);
}

// The cutting edge as lines a drawing puts over the blade: one along each face's lower corner, a
// hair outside the face so the face never hides it from its own side (and the blade does from the
// other). Four points: two segments heel → tip.
inline void blade_edge_lines(const BladeShape& s, Vec3 (&out)[4]) noexcept {
  const Vec3 side = s.axis.cross(s.back).normalized() * (0.55 * s.thickness + 5e-6);
  const Vec3 heel = s.heel();
  out[0] = heel + side, out[1] = s.tip + side, out[2] = heel - side, out[3] = s.tip - side;
}

// The handle: a flat bar from the heel back along −axis, centred on the blade's half depth.
inline void append_blade_handle(BladeMesh& m, const BladeShape& s) {
  const Vec3 side = s.axis.cross(s.back).normalized();
  const Vec3 a = s.heel() + 0.5 * s.depth * s.back, b = a - s.handle_length * s.axis;
  const Vec3 w = 0.5 * s.handle_width * s.back;
  blade_detail::add_prism(m, {a - w, a + w, b + w, b - w}, side, 0.5 * s.handle_thickness);
}

}  // namespace palpate
