// contact.cpp — the surface contact of the tool's sphere or needle against the organ's surface
// triangles, made implicit by a per-tick correction (docs/models/mass-spring.md, "Contact").
#include <palpate/spring.h>

#include "core/triangle.h"
#include "tissue/spring/stages.h"

#include <algorithm>
#include <cmath>

namespace palpate::spring {

namespace {

// Closest points of the segments [p1, q1] and [p2, q2] (Ericson 2005, §5.1.9): their parameters
// s, t in [0, 1]. Parallel segments have a set of closest pairs; then s is the middle of the part of
// [p1, q1] that faces [p2, q2] (a shaft lying along an edge is carried at the middle of the overlap).
void closest_on_segments(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2, double& s,
                         double& t) noexcept {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  if (!(a > 0) && !(e > 0)) { s = t = 0; return; }
  if (!(a > 0)) { s = 0; t = std::clamp(f / e, 0.0, 1.0); return; }
  const double c = d1.dot(r);
  if (!(e > 0)) { t = 0; s = std::clamp(-c / a, 0.0, 1.0); return; }
  const double b = d1.dot(d2), denom = a * e - b * b;
  if (denom > 1e-12 * a * e) {
    s = std::clamp((b * f - c * e) / denom, 0.0, 1.0);
  } else {  // parallel: the middle of [p1, q1]'s part over [p2, q2]
    const double s0 = std::clamp(-c / a, 0.0, 1.0), s1 = std::clamp((b - c) / a, 0.0, 1.0);
    s = 0.5 * (s0 + s1);
  }
  t = (b * s + f) / e;
  if (t < 0) { t = 0; s = std::clamp(-c / a, 0.0, 1.0); }
  else if (t > 1) { t = 1; s = std::clamp((b - c) / a, 0.0, 1.0); }
}

// The closest points of the segment [p0, p1] (a needle's shaft) and the triangle (a, b, c): q on the
// segment, the point on the triangle returned with its barycentric weights w; the distance is
// |q − returned|. Candidates (Ericson 2005, §5.1.10): each end against the triangle, the segment
// against each edge; a segment through the triangle is at distance 0 (q = the crossing). A shaft
// lying parallel to the face (within 1e-3 rad) over it has a set of closest pairs: it is then carried
// at the middle of its part over the triangle (clipped against the three edges), so that a needle laid
// on a face loads it symmetrically, not at whichever end round-off picks.
Vec3 closest_segment_triangle(const Vec3& p0, const Vec3& p1, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& q,
                              Vec3& w) noexcept {
  const Vec3 d = p1 - p0, nf = (b - a).cross(c - a);
  const double len2 = d.squaredNorm(), area2 = nf.squaredNorm();
  if (area2 > 0 && len2 > 0) {
    const double h0 = nf.dot(p0 - a), h1 = nf.dot(p1 - a);
    const Vec3 edge[3][2] = {{a, b}, {b, c}, {c, a}};
    if ((h0 < 0 && h1 > 0) || (h0 > 0 && h1 < 0)) {  // crosses the plane: inside the triangle?
      const Vec3 x = p0 + (h0 / (h0 - h1)) * d;
      bool in = true;
      for (const auto& E : edge) in = in && nf.dot((E[1] - E[0]).cross(x - E[0])) >= 0;
      if (in) {
        q = x;
        return closest_on_triangle(x, a, b, c, w);
      }
    }
    if (std::abs(nf.dot(d)) <= 1e-3 * std::sqrt(area2 * len2)) {
      // Parallel to the face: the part of the segment whose projection lies inside (Cyrus–Beck).
      double lo = 0, hi = 1;
      for (const auto& E : edge) {
        const Vec3 m = nf.cross(E[1] - E[0]);  // in the plane, pointing into the triangle
        const double g0 = m.dot(p0 - E[0]), gd = m.dot(d);
        if (gd > 0) lo = std::max(lo, -g0 / gd);
        else if (gd < 0) hi = std::min(hi, -g0 / gd);
        else if (g0 < 0) hi = -1;
      }
      if (lo <= hi) {
        q = p0 + (0.5 * (lo + hi)) * d;
        return closest_on_triangle(q, a, b, c, w);
      }
    }
  }
  Vec3 wk;
  Vec3 best = closest_on_triangle(p0, a, b, c, w);
  q = p0;
  double best_d2 = (p0 - best).squaredNorm();
  {
    const Vec3 pk = closest_on_triangle(p1, a, b, c, wk);
    const double d2 = (p1 - pk).squaredNorm();
    if (d2 < best_d2) { best_d2 = d2; best = pk; q = p1; w = wk; }
  }
  const Vec3 corner[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const Vec3 &e0 = corner[k], &e1 = corner[(k + 1) % 3];
    double s, t;
    closest_on_segments(p0, p1, e0, e1, s, t);
    const Vec3 qs = p0 + s * d, pe = e0 + t * (e1 - e0);
    const double d2 = (qs - pe).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = pe;
      q = qs;
      w.setZero();
      w[k] = 1 - t;
      w[(k + 1) % 3] = t;
    }
  }
  return best;
}

}  // namespace

// Surface contact, after the solve (docs/models/mass-spring.md, "Contact"). The tool's sphere
// (centre c, radius r) against the surface triangles at the new positions: each triangle t whose
// closest point p_t lies within r, on its outer side, is pressed with weight φ_t = r − |c − p_t|
// along n_t = (c − p_t)/|c − p_t| (weights ω_t ∝ φ_t with |Σ ω_t n_t| = 1); a centre inside a closed surface presses only the nearest
// triangle, by r + its distance, along its outward normal, so the tool is pushed out. The depth
// Φ = max φ_t. The force F on the tool is a penalty k_c Φ, made stable whatever the vertex masses
// by solving for it implicitly each tick against the contact vertices' compliance
// c = Σ_i |g_i|² / (m_i + hγ), g_i = Σ_t (φ_t / Σφ) w_t,i n_t (an upper bound of the true one, since
// A ≥ M + hγ: the update under-relaxes, never overshoots):
//   F⁺ = max(0, k_c (Φ + h² c F) / (1 + k_c h² c)),
// the step having already carried F. The difference F⁺ − F moves the contact vertices now
// (Δv_i = −h (F⁺ − F) g_i / (m_i + hγ)) and acts as −F⁺ g_i in the next step. At rest F⁺ = F, so
// F = k_c Φ: a penalty of stiffness k_c in series with the tissue, independent of the masses.
// A needle (tool.needle, tool.length > 0) is a capsule: each triangle is pressed from the shaft's
// point closest to it (closest_segment_triangle) instead of the centre, and once in contact a
// triangle the shaft has been pushed behind presses it by r plus that distance along its normal.
void surface_contact(const SpringModel& model, SpringState& s, const ToolState& tool) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt, kc = model.options.contact_stiffness;
  const double r = std::max(tool.radius, 0.0);
  const double f_prev = s.contact_vertex_count > 0 ? s.contact_force : 0.0;
  // Whether the centre may be inside a closed surface deeper than r (then no triangle is within r
  // and the nearest one decides): only after a contact (the tool went in through the surface, or
  // faster than r per step) or on the first step (a tool that starts inside). Otherwise the pass
  // over the triangles is a bounding-box test each.
  const bool search_inside = model.closed_surface && (s.contact_vertex_count > 0 || s.time == 0);
  const double depth_prev = s.contact_vertex_count > 0 ? s.contact_depth : 0.0;
  s.tool_force -= s.carried_on_tool;  // replaced below by the corrected force
  s.carried_on_tool.setZero();
  s.contact_vertex_count = 0;
  s.contact_force = 0;
  s.contact_depth = 0;
  s.contacts = 0;
  if (r <= 0 || kc <= 0 || net.triangles.empty()) return;
  const Vec3 c = tool.tip;
  // A needle's shaft: the segment [tip − length·axis, tip] of radius r (a capsule), each triangle
  // pressed from the shaft's point closest to it. A sphere (or a needle of no length): the tip only.
  const double axis_norm = tool.axis.norm();
  // (A blade's edge is pressed along its length as a needle's shaft is.)
  const bool shaft = (tool.needle || tool.blade) && tool.length > 0 && axis_norm > 0;
  const Vec3 back = shaft ? Vec3(c - (tool.length / axis_norm) * tool.axis) : c;
  const Vec3 tool_lo = c.cwiseMin(back), tool_hi = c.cwiseMax(back);
  // A shaft that was in contact may have been pushed behind the faces it presses (the depth is not
  // bounded by a thin needle's radius, as the tip's is by the inside test): a triangle whose plane
  // the shaft's closest point is behind, over the triangle, by less than the last depth plus r,
  // still presses it, by r plus that distance, along its outward normal. Only on a closed surface
  // (inside is defined), after a contact (it went in through the surface).
  const double behind = shaft && model.closed_surface && depth_prev > 0 ? depth_prev + r : 0.0;
  const double reach = r + behind;
  // Triangles within reach of the tool (the deepest kept when there are more than fit), and the
  // nearest triangle to the tip overall when the tip may be inside.
  struct Hit {
    int tri;
    double dist;   // m, from the tool's point to the triangle's
    Vec3 w, p, q;  // barycentric weights and point on the triangle; the tool's point closest to it
    double phi;    // m, the depth it is pressed by
    Vec3 n;        // its direction (unit), out of the organ
    bool behind = false;  // a shaft pushed behind the face: the whole triangle pressed by phi along n
  };
  std::array<Hit, SpringState::kMaxContactTriangles> hits;
  int nhits = 0;
  int nearest = -1;
  double nearest_d2 = std::numeric_limits<double>::infinity(), nearest_cos = 0;
  Vec3 nearest_w = Vec3::Zero(), nearest_p = Vec3::Zero();
  auto visit = [&](size_t t) {
    const auto& T = net.triangles[t];
    const Vec3 a = s.x.row(T[0]).transpose(), b = s.x.row(T[1]).transpose(), q = s.x.row(T[2]).transpose();
    // Bounding-box distance first: most triangles are far.
    const Vec3 lo = a.cwiseMin(b).cwiseMin(q), hi = a.cwiseMax(b).cwiseMax(q);
    const double box_d2 = (c.cwiseMax(lo).cwiseMin(hi) - c).squaredNorm();
    const double tool_box_d2 =
        shaft ? (lo - tool_hi).cwiseMax(tool_lo - hi).cwiseMax(0.0).squaredNorm() : box_d2;
    if (tool_box_d2 >= reach * reach && (!search_inside || box_d2 > nearest_d2)) return;
    Vec3 w;
    const Vec3 p = closest_on_triangle(c, a, b, q, w);
    const double d2 = (c - p).squaredNorm();
    if (model.closed_surface) {
      // Nearest triangle; at a shared edge or corner (equal distances), the one whose plane the
      // centre is most clearly in front of or behind decides the side (its |cos| is largest).
      const Vec3 nf = (b - a).cross(q - a);
      const double len = nf.norm() * std::sqrt(d2);
      const double cosine = len > 0 ? (c - p).dot(nf) / len : 0.0;
      const bool tie = std::abs(d2 - nearest_d2) <= 1e-12 * std::max(d2, 1e-30);
      if (d2 < nearest_d2 && !tie) {
        nearest = static_cast<int>(t); nearest_d2 = d2; nearest_cos = cosine; nearest_w = w; nearest_p = p;
      } else if (tie && std::abs(cosine) > std::abs(nearest_cos)) {
        nearest = static_cast<int>(t); nearest_cos = cosine; nearest_w = w; nearest_p = p;
      }
    }
    Hit hit{static_cast<int>(t), 0.0, w, p, c, 0.0, Vec3::Zero(), false};
    if (shaft) {
      if (tool_box_d2 >= reach * reach) return;
      hit.p = closest_segment_triangle(back, c, a, b, q, hit.q, hit.w);
      hit.dist = (hit.q - hit.p).norm();
      const Vec3 nf = (b - a).cross(q - a);
      const double side = (hit.q - hit.p).dot(nf);
      const bool over = hit.w.minCoeff() > 0;  // the shaft's point is over the triangle, not past an edge
      if (hit.dist < r && side > 0) {
        hit.phi = r - hit.dist;
        hit.n = (hit.q - hit.p) / hit.dist;
      } else if (behind > 0 && over && hit.dist < behind && side <= 0 && nf.squaredNorm() > 0) {
        hit.phi = r + hit.dist;  // behind the face (or through it): pushed out along its normal
        hit.behind = true;
        hit.n = nf.normalized();
      } else {
        return;
      }
    } else {
      if (d2 >= r * r) return;
      hit.dist = std::sqrt(d2);
      hit.phi = r - hit.dist;
    }
    if (nhits < SpringState::kMaxContactTriangles) {
      hits[static_cast<size_t>(nhits++)] = hit;
    } else {
      int far = 0;
      for (int k = 1; k < nhits; ++k) if (hits[static_cast<size_t>(k)].phi < hits[static_cast<size_t>(far)].phi) far = k;
      if (hit.phi > hits[static_cast<size_t>(far)].phi) hits[static_cast<size_t>(far)] = hit;
    }
    };
  // The cull: each surface vertex's outcode against the tool's box grown by reach (a bit per side per
  // axis); a triangle whose three corners share a bit lies wholly outside that box, so its bounding
  // box is farther than reach from the tool (it can be no hit) and from the tip. Those are visited
  // only when the nearest triangle is wanted and none within reach was found among the others.
  const size_t n_vertices = static_cast<size_t>(s.x.rows());
  const bool cull = s.contact_code.size() == n_vertices && !model.surface_vertices.empty();
  if (cull) {
    const Vec3 lo = tool_lo - Vec3::Constant(reach), hi = tool_hi + Vec3::Constant(reach);
    const double* xd = s.x.data();
    for (const int v : model.surface_vertices) {
      const double* p = xd + 3 * static_cast<size_t>(v);
      s.contact_code[static_cast<size_t>(v)] = static_cast<std::uint8_t>(
          (p[0] < lo.x()) | (p[0] > hi.x()) << 1 | (p[1] < lo.y()) << 2 | (p[1] > hi.y()) << 3 |
          (p[2] < lo.z()) << 4 | (p[2] > hi.z()) << 5);
    }
    const std::uint8_t* code = s.contact_code.data();
    const auto outside = [&](size_t t) {
      const auto& T = net.triangles[t];
      return (code[T[0]] & code[T[1]] & code[T[2]]) != 0;
    };
    for (size_t t = 0; t < net.triangles.size(); ++t)
      if (!outside(t)) visit(t);
    if (search_inside && !(nearest_d2 < reach * reach))
      for (size_t t = 0; t < net.triangles.size(); ++t)
        if (outside(t)) visit(t);
  } else {
    for (size_t t = 0; t < net.triangles.size(); ++t) visit(t);
  }
  // (A shaft that presses triangles is carried by them even when its tip is inside.)
  const bool inside = model.closed_surface && nearest >= 0 && nearest_cos < 0 &&
                      (search_inside || nearest_d2 < r * r) && !(shaft && nhits > 0);
  // Contact vertices and their direction sums g_i (up to kMaxContactVertices).
  std::array<Vec3, SpringState::kMaxContactVertices> g;
  const bool slots = s.contact_slot.size() == static_cast<size_t>(s.x.rows());
  auto add = [&](int vertex, const Vec3& gi) {
    if (slots) {
      int& slot = s.contact_slot[static_cast<size_t>(vertex)];
      if (slot >= 0) { g[static_cast<size_t>(slot)] += gi; return; }
      if (s.contact_vertex_count == SpringState::kMaxContactVertices) return;
      slot = s.contact_vertex_count;
    } else {
      for (int k = 0; k < s.contact_vertex_count; ++k)
        if (s.contact_vertex[static_cast<size_t>(k)] == vertex) { g[static_cast<size_t>(k)] += gi; return; }
      if (s.contact_vertex_count == SpringState::kMaxContactVertices) return;
    }
    s.contact_vertex[static_cast<size_t>(s.contact_vertex_count)] = vertex;
    g[static_cast<size_t>(s.contact_vertex_count++)] = gi;
  };
  auto clear_slots = [&] {
    if (slots)
      for (int k = 0; k < s.contact_vertex_count; ++k) s.contact_slot[static_cast<size_t>(s.contact_vertex[static_cast<size_t>(k)])] = -1;
  };
  // The tool's pressure over the part of triangle t inside it (docs/models/mass-spring.md, Contact):
  // p ∝ the local depth r − |q − x| along (q − x)/|q − x|, q the tool's point nearest x (the centre
  // of a sphere; on a needle's shaft, the segment's point nearest x), integrated at the centroids of
  // an N × N split of the triangle (N = ⌈6 × its longest rest edge / r⌉, 2 to 6) and shared by each
  // point's barycentric weights. Added to g unscaled; returns the triangle's resultant. Each point
  // joins with zero depth, so the load moves continuously as the patch grows over the mesh.
  const Vec3 axis_seg = c - back;
  const double axis_len2 = axis_seg.squaredNorm();
  auto rest_edge_of = [&](int tri) {
    const auto& T = net.triangles[static_cast<size_t>(tri)];
    return std::sqrt(std::max({(net.rest.row(T[1]) - net.rest.row(T[0])).squaredNorm(),
                               (net.rest.row(T[2]) - net.rest.row(T[1])).squaredNorm(),
                               (net.rest.row(T[0]) - net.rest.row(T[2])).squaredNorm()}));
  };
  auto spread_over_area = [&](int tri) -> Vec3 {
    const auto& T = net.triangles[static_cast<size_t>(tri)];
    const Vec3 a = s.x.row(T[0]).transpose(), b = s.x.row(T[1]).transpose(), q = s.x.row(T[2]).transpose();
    const double rest_edge = rest_edge_of(tri);
    const int N = static_cast<int>(std::clamp(std::ceil(6.0 * rest_edge / r), 2.0, 6.0));
    const double dA = 0.5 * (b - a).cross(q - a).norm() / (N * N);
    Vec3 corner[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
    Vec3 total = Vec3::Zero();
    const double r2 = r * r;
    for (int i = 0; i < N; ++i)
      for (int j = 0; i + j < N; ++j)
        for (int down = 0; down < 2; ++down) {
          if (down && i + j > N - 2) break;
          const double u = (i + (down ? 2.0 : 1.0) / 3.0) / N, v = (j + (down ? 2.0 : 1.0) / 3.0) / N;
          const double w0 = 1.0 - u - v;
          const Vec3 x = w0 * a + u * b + v * q;
          Vec3 d = c - x;
          if (axis_len2 > 0) {
            const double along = std::clamp((x - back).dot(axis_seg) / axis_len2, 0.0, 1.0);
            if (along < 1.0) d = back + along * axis_seg - x;
          }
          const double dist2 = d.squaredNorm();
          if (dist2 >= r2) continue;
          const double dist = std::sqrt(dist2);
          if (!(dist > 1e-12 * r)) continue;
          const Vec3 load = ((r - dist) * dA / dist) * d;
          corner[0] += w0 * load;
          corner[1] += u * load;
          corner[2] += v * load;
          total += load;
        }
    for (int k = 0; k < 3; ++k)
      if (corner[k].squaredNorm() > 0) add(T[static_cast<size_t>(k)], corner[k]);
    return total;
  };
  double depth = 0;
  if (inside) {
    const auto& T = net.triangles[static_cast<size_t>(nearest)];
    const Vec3 a = s.x.row(T[0]).transpose(), b = s.x.row(T[1]).transpose(), q = s.x.row(T[2]).transpose();
    const Vec3 n = (b - a).cross(q - a).normalized();  // outward
    depth = r + std::sqrt(nearest_d2);
    for (int k = 0; k < 3; ++k) add(T[static_cast<size_t>(k)], nearest_w[k] * n);
    s.contacts = 1;
  } else {
    double sum = 0;
    int used = 0;
    for (int k = 0; k < nhits; ++k) {
      Hit hit = hits[static_cast<size_t>(k)];
      if (!shaft) {
        if (!(hit.dist > 1e-12 * r)) continue;  // the centre on the surface: no direction (rare; next tick)
        if (model.closed_surface) {  // only triangles the tool is in front of (not the back of a thin part)
          const auto& T = net.triangles[static_cast<size_t>(hit.tri)];
          const Vec3 nf = (s.x.row(T[1]) - s.x.row(T[0])).transpose().cross((s.x.row(T[2]) - s.x.row(T[0])).transpose());
          if ((hit.q - hit.p).dot(nf) < 0) continue;
        }
        hit.n = (hit.q - hit.p) / hit.dist;
      }
      sum += hit.phi;
      depth = std::max(depth, hit.phi);
      hits[static_cast<size_t>(used++)] = hit;
    }
    // The pressure over each triangle's area inside the tool (a triangle a shaft was pushed behind:
    // its whole area at its depth φ_t, at the shaft's closest point), scaled so that Σ_i g_i is a
    // unit vector (the tool feels exactly F along it).
    // Only where the triangles are small against the tool (every pressed triangle's longest rest
    // edge ≤ r/2: the patch spans several of them, and rings of vertices join it as it grows). On a
    // mesh coarse against the tool the patch lies on one or two triangles and each triangle's
    // closest point carries it (below), as validated there (docs/models/mass-spring.md, Contact).
    bool resolved = used > 0;
    for (int k = 0; k < used && resolved; ++k)
      resolved = hits[static_cast<size_t>(k)].behind || rest_edge_of(hits[static_cast<size_t>(k)].tri) <= 0.5 * r;
    bool spread = false;
    if (resolved) {
      Vec3 resultant = Vec3::Zero();
      for (int k = 0; k < used; ++k) {
        const Hit& hit = hits[static_cast<size_t>(k)];
        if (!hit.behind) {
          resultant += spread_over_area(hit.tri);
          continue;
        }
        const auto& T = net.triangles[static_cast<size_t>(hit.tri)];
        const double area = 0.5 * (s.x.row(T[1]) - s.x.row(T[0]))
                                      .transpose()
                                      .cross((s.x.row(T[2]) - s.x.row(T[0])).transpose())
                                      .norm();
        const Vec3 load = hit.phi * area * hit.n;
        for (int q = 0; q < 3; ++q)
          if (hit.w[q] > 0) add(T[static_cast<size_t>(q)], hit.w[q] * load);
        resultant += load;
      }
      const double norm = resultant.norm();
      if (norm > 0) {
        for (int k = 0; k < s.contact_vertex_count; ++k) g[static_cast<size_t>(k)] /= norm;
        spread = true;
      } else {
        clear_slots();
        s.contact_vertex_count = 0;
      }
    }
    // A needle's shaft, or a patch smaller than the sampling above (a first touch, a small probe on
    // a coarse mesh): each triangle's weight φ_t at its closest point, scaled so that Σ ω_t n_t is a
    // unit vector.
    Vec3 resultant = Vec3::Zero();
    for (int k = 0; k < used; ++k) resultant += hits[static_cast<size_t>(k)].phi * hits[static_cast<size_t>(k)].n;
    sum = resultant.norm();
    if (sum > 0 && !spread)
      for (int k = 0; k < used; ++k) {
        const Hit& hit = hits[static_cast<size_t>(k)];
        const Vec3 n = hit.n;
        const double weight = hit.phi / sum;
        const auto& T = net.triangles[static_cast<size_t>(hit.tri)];
        for (int q = 0; q < 3; ++q)
          if (hit.w[q] > 0) add(T[static_cast<size_t>(q)], weight * hit.w[q] * n);
      }
    s.contacts = used;
  }
  clear_slots();
  if (!(depth > 0) || s.contact_vertex_count == 0) {
    s.contact_vertex_count = 0;
    s.contacts = 0;
    return;
  }
  double compliance = 0;
  if (model.contact_compliance_exact) {  // (A⁻¹)_ii: the Cauchy–Schwarz bound (Σ_i |g_i| √(A⁻¹)_ii)²
    for (int k = 0; k < s.contact_vertex_count; ++k)
      compliance += g[static_cast<size_t>(k)].norm() *
                    std::sqrt(model.contact_compliance[static_cast<size_t>(s.contact_vertex[static_cast<size_t>(k)])]);
    compliance *= compliance;
  } else {
    for (int k = 0; k < s.contact_vertex_count; ++k)
      compliance += g[static_cast<size_t>(k)].squaredNorm() *
                    model.contact_compliance[static_cast<size_t>(s.contact_vertex[static_cast<size_t>(k)])];
  }
  // The normal damper (contact_damping) on the approach speed of the tool to the contact vertices
  // along the force's direction: explicit, so small (it is zero at rest).
  Vec3 surface_v = Vec3::Zero(), direction = Vec3::Zero();
  for (int k = 0; k < s.contact_vertex_count; ++k) {
    const int i = s.contact_vertex[static_cast<size_t>(k)];
    direction += g[static_cast<size_t>(k)];
    surface_v += g[static_cast<size_t>(k)].norm() * s.v.row(i).transpose();
  }
  const double gsum = direction.norm();
  const double approach = gsum > 0 ? (surface_v / gsum - tool.velocity).dot(direction / gsum) : 0.0;
  const double kh2c = kc * h * h * compliance;
  const double f_new = std::max(
      0.0, (kc * (depth + h * h * compliance * f_prev) + model.options.contact_damping * approach) / (1 + kh2c));
  const double df = f_new - f_prev;
  Vec3 total = Vec3::Zero();
  for (int k = 0; k < s.contact_vertex_count; ++k) {
    const int i = s.contact_vertex[static_cast<size_t>(k)];
    const Vec3 gi = g[static_cast<size_t>(k)];
    const Vec3 dv = -h * df * model.contact_compliance[static_cast<size_t>(i)] * gi;
    s.v.row(i) += dv.transpose();
    s.x.row(i) += h * dv.transpose();
    s.contact_load[static_cast<size_t>(k)] = -f_new * gi;
    total += f_new * gi;
  }
  s.contact_force = f_new;
  s.contact_depth = depth;
  s.tool_force += total;  // the tool feels F⁺, the corrected force, now
}

}  // namespace palpate::spring
