// model.cpp — building a charged-particle patch: generated hexagonal lattices (flat, cylinder,
// sphere), patches laid on a surface mesh, the rest state, and the per-particle memory figure.
#include <palpate/charged.h>

#include "core/memory.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace palpate {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr size_t kMaxParticles = size_t{1} << 27;  // 134 M: int32 indices with room to spare

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::int16_t snorm16(double v) {
  return static_cast<std::int16_t>(std::lround(std::clamp(v, -1.0, 1.0) * 32767.0));
}

// The material checks shared by every layout. `spacing` is the largest rest distance between
// neighbours: the separation rule can only hold at rest when the separation limit exceeds it.
// Returns the separation limit S (m): max_separation when set, else (1 + max_strain) · spacing.
Result<double> check_material(const ChargedMaterialDef& m, double spacing, const std::string& where) {
  for (auto [v, key, unit] : {std::tuple{m.max_displacement, "max_displacement", "m"},
                              std::tuple{m.max_strain, "max_strain", ""},
                              std::tuple{m.puncture_force, "puncture_force", "N"},
                              std::tuple{m.thickness, "thickness", "m"},
                              std::tuple{m.friction_presliding, "friction_presliding", "m"}})
    if (!(std::isfinite(v) && v > 0))
      return Error{where + ": material '" + key + "' is " + num(v) + (*unit ? " " : "") + unit +
                   "; expected a finite value > 0"};
  for (auto [v, key] : {std::pair{m.elasticity, "elasticity"}, std::pair{m.particle_radius, "particle_radius"},
                        std::pair{m.max_separation, "max_separation"}, std::pair{m.puncture_time, "puncture_time"},
                        std::pair{m.friction_per_length, "friction_per_length"},
                        std::pair{m.cutting_force, "cutting_force"},
                        std::pair{m.cutting_drag_per_length, "cutting_drag_per_length"},
                        std::pair{m.wound_gap, "wound_gap"}})
    if (!(std::isfinite(v) && v >= 0))
      return Error{where + ": material '" + key + "' is " + num(v) + "; expected a finite value >= 0"};
  for (auto [v, key] : {std::pair{m.linear_share, "linear_share"}, std::pair{m.snap_share, "snap_share"}})
    if (!(std::isfinite(v) && v >= 0 && v <= 1))
      return Error{where + ": material '" + key + "' is " + num(v) + "; expected a value in [0, 1]"};
  if (m.force_model != "indentation" && m.force_model != "coulomb")
    return Error{where + ": material 'force_model' is '" + m.force_model + "'; expected indentation or coulomb"};
  for (auto [v, key] : {std::pair{m.particle_charge, "particle_charge"}, std::pair{m.hip_charge, "hip_charge"}})
    if (!(std::isfinite(v) && v > 0))
      return Error{where + ": material '" + key + "' is " + num(v) + " C; expected a finite value > 0"};
  if (m.max_separation > 0) {
    if (!(m.max_separation > spacing))
      return Error{where + ": material 'max_separation' (" + num(m.max_separation) +
                   " m) must exceed the rest distance between neighbours (" + num(spacing) +
                   " m), or the patch would violate the separation rule at rest"};
    return m.max_separation;
  }
  return (1 + m.max_strain) * spacing;
}

constexpr double kCoulomb = 8.9875517923e9;  // N·m²/C², k_e = 1/(4π ε0)

void set_force_model(ChargedModel& m) {
  m.coulomb = m.material.force_model == "coulomb";
  m.coulomb_kqq = kCoulomb * m.material.hip_charge * m.material.particle_charge;
}

// Unit tangents completing `n` to a right-handed frame (u, v, n): u ⟂ n, v = n × u.
void frame(const Vec3& n, Vec3& u, Vec3& v) {
  Vec3 e = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitZ();
  u = (e - e.dot(n) * n).normalized();
  v = n.cross(u);
}

void fill_state_arrays(const ChargedModel& m, ChargedState& s) {
  const size_t n = m.size();
  s.x = m.origin_x;
  s.y = m.origin_y;
  s.z = m.origin_z;
  s.flags.assign(n, 0);
  s.active.assign(n, 0);
  s.queue.assign(n, 0);
  s.cut.assign(n, 0);
  s.wound.assign(std::min(n, kChargedMaxWound), ChargedWound{});
  size_t slots = 2;
  while (slots < 2 * s.wound.size()) slots *= 2;
  s.wound_index.assign(slots, -1);
  s.cut_scratch.assign(n, 0);
  s.wound_count = 0;
  s.cut_link_count = 0;
}

}  // namespace

int ChargedModel::neighbours_of(int i, std::array<int, 6>& out) const noexcept {
  int k = 0;
  if (layout == ChargedLayout::mesh) {
    const std::int32_t* nb = neighbours.data() + static_cast<size_t>(i) * 6;
    for (int j = 0; j < 6; ++j)
      if (nb[j] >= 0) out[static_cast<size_t>(k++)] = nb[j];
    return k;
  }
  // Hexagonal lattice, odd rows shifted +spacing/2 along u: the rows above and below hold the
  // neighbours at columns (c-1, c) from an even row and (c, c+1) from an odd row.
  const int r = i / cols, c = i - r * cols;
  if (c > 0) out[static_cast<size_t>(k++)] = i - 1;
  if (c + 1 < cols) out[static_cast<size_t>(k++)] = i + 1;
  const int c0 = (r & 1) ? c : c - 1;
  for (int dr : {-1, 1}) {
    const int rr = r + dr;
    if (rr < 0 || rr >= rows) continue;
    for (int cc = c0; cc <= c0 + 1; ++cc)
      if (cc >= 0 && cc < cols) out[static_cast<size_t>(k++)] = rr * cols + cc;
  }
  return k;
}

void ChargedModel::neighbour_slots(int i, std::array<int, 6>& out) const noexcept {
  out.fill(-1);
  if (layout == ChargedLayout::mesh) {
    const std::int32_t* nb = neighbours.data() + static_cast<size_t>(i) * 6;
    for (size_t j = 0; j < 6; ++j) out[j] = nb[j];
    return;
  }
  const int r = i / cols, c = i - r * cols;
  if (c > 0) out[0] = i - 1;
  if (c + 1 < cols) out[1] = i + 1;
  const int c0 = (r & 1) ? c : c - 1;
  for (int dr : {-1, 1}) {
    const int rr = r + dr;
    if (rr < 0 || rr >= rows) continue;
    for (int cc = c0; cc <= c0 + 1; ++cc)
      if (cc >= 0 && cc < cols) out[static_cast<size_t>((dr < 0 ? 2 : 4) + (cc - c0))] = rr * cols + cc;
  }
}

int charged_slot_of(const ChargedModel& m, int i, int j) noexcept {
  std::array<int, 6> nb{};
  m.neighbour_slots(i, nb);
  for (int k = 0; k < 6; ++k)
    if (nb[static_cast<size_t>(k)] == j) return k;
  return -1;
}

const ChargedWound* charged_wound_of(const ChargedState& s, int i) noexcept {
  if (s.wound_count == 0) return nullptr;
  const size_t mask = s.wound_index.size() - 1;
  for (size_t k = (static_cast<std::uint32_t>(i) * 2654435761u) & mask;; k = (k + 1) & mask) {
    const std::int32_t w = s.wound_index[k];
    if (w < 0) return nullptr;
    if (s.wound[static_cast<size_t>(w)].particle == i) return &s.wound[static_cast<size_t>(w)];
  }
}

Result<ChargedModel> build_charged_patch(const PatchDef& p, const ChargedMaterialDef& material,
                                         const std::string& where) {
  ChargedModel m;
  m.material = material;
  set_force_model(m);
  if (p.shape == "flat") m.layout = ChargedLayout::flat;
  else if (p.shape == "cylinder") m.layout = ChargedLayout::cylinder;
  else if (p.shape == "sphere") m.layout = ChargedLayout::sphere;
  else return Error{where + ": patch 'shape' is '" + p.shape + "'; expected flat, cylinder or sphere" +
                    (p.shape == "gallbladder" ? " (gallbladder is a mass_spring organ's shape)" : "")};
  for (auto [v, key] : {std::pair{p.width, "width"}, std::pair{p.height, "height"},
                        std::pair{p.spacing, "spacing"}})
    if (!(std::isfinite(v) && v > 0))
      return Error{where + ": patch '" + key + "' is " + num(v) + " m; expected a finite value > 0"};
  if (!p.center.allFinite()) return Error{where + ": patch 'center' is not finite"};
  if (!p.normal.allFinite() || p.normal.norm() < 1e-12)
    return Error{where + ": patch 'normal' must be a finite, non-zero vector"};
  if (m.layout != ChargedLayout::flat) {
    if (!(std::isfinite(p.radius) && p.radius > 0))
      return Error{where + ": patch 'radius' is " + num(p.radius) + " m; expected > 0 for a " + p.shape};
    if (p.width >= 2 * kPi * p.radius)
      return Error{where + ": patch 'width' (" + num(p.width) + " m) must be less than the " + p.shape +
                   "'s circumference 2π·radius (" + num(2 * kPi * p.radius) + " m)"};
    if (m.layout == ChargedLayout::sphere && p.height >= kPi * p.radius)
      return Error{where + ": patch 'height' (" + num(p.height) +
                   " m) must be less than half the sphere's circumference π·radius (" +
                   num(kPi * p.radius) + " m)"};
  }
  if (p.width < p.spacing || p.height < p.spacing * std::sqrt(3.0) / 2)
    return Error{where + ": patch 'spacing' (" + num(p.spacing) + " m) leaves fewer than two particles "
                 "across width " + num(p.width) + " m or height " + num(p.height) + " m"};
  Result<double> separation = check_material(material, p.spacing, where);
  if (!separation) return separation.error();

  m.spacing = p.spacing;
  m.row_pitch = p.spacing * std::sqrt(3.0) / 2;
  const double cols = std::floor(p.width / p.spacing + 1e-9) + 1;
  const double rows = std::floor(p.height / m.row_pitch + 1e-9) + 1;
  if (cols * rows > static_cast<double>(kMaxParticles))
    return Error{where + ": patch of " + num(cols) + " x " + num(rows) + " particles exceeds the limit of " +
                 num(static_cast<double>(kMaxParticles)) + "; use a larger 'spacing'"};
  m.cols = static_cast<int>(cols);
  m.rows = static_cast<int>(rows);
  m.u_mid = ((m.cols - 1) * m.spacing + 0.5 * m.spacing) / 2;
  m.v_mid = (m.rows - 1) * m.row_pitch / 2;
  m.center = p.center;
  m.normal = p.normal.normalized();
  frame(m.normal, m.tangent_u, m.tangent_v);
  m.radius = m.layout == ChargedLayout::flat ? 0.0 : p.radius;
  m.max_separation = *separation;

  const size_t n = static_cast<size_t>(m.rows) * static_cast<size_t>(m.cols);
  m.origin_x.resize(n), m.origin_y.resize(n), m.origin_z.resize(n);
  m.normal_x.resize(n), m.normal_y.resize(n), m.normal_z.resize(n);
  const Vec3 axis_point = m.center - m.radius * m.normal;  // cylinder axis / sphere centre
  for (int r = 0; r < m.rows; ++r) {
    for (int c = 0; c < m.cols; ++c) {
      // Integer offsets from the patch centre, one rounding each: a particle at the same place
      // relative to the centre has bit-identical coordinates in patches of any size.
      const double u = (4 * c + 2 * (r & 1) - (2 * m.cols - 1)) * (m.spacing / 4);
      const double v = (2 * r - (m.rows - 1)) * (m.row_pitch / 2);
      Vec3 pos, nrm;
      switch (m.layout) {
        case ChargedLayout::cylinder: {
          const double phi = u / m.radius;
          nrm = std::sin(phi) * m.tangent_u + std::cos(phi) * m.normal;
          pos = axis_point + m.radius * nrm + v * m.tangent_v;
          break;
        }
        case ChargedLayout::sphere: {
          const double phi = u / m.radius, theta = v / m.radius;
          nrm = std::cos(theta) * (std::sin(phi) * m.tangent_u + std::cos(phi) * m.normal) +
                std::sin(theta) * m.tangent_v;
          pos = axis_point + m.radius * nrm;
          break;
        }
        default:
          nrm = m.normal;
          pos = m.center + u * m.tangent_u + v * m.tangent_v;
      }
      const size_t i = static_cast<size_t>(r) * static_cast<size_t>(m.cols) + static_cast<size_t>(c);
      m.origin_x[i] = static_cast<float>(pos.x());
      m.origin_y[i] = static_cast<float>(pos.y());
      m.origin_z[i] = static_cast<float>(pos.z());
      m.normal_x[i] = snorm16(nrm.x()), m.normal_y[i] = snorm16(nrm.y()), m.normal_z[i] = snorm16(nrm.z());
    }
  }
  // Triangles of the lattice, counter-clockwise seen from the outward normal (cold, for drawing).
  m.triangles.reserve(2 * n);
  for (int r = 0; r + 1 < m.rows; ++r) {
    const int a = r * m.cols, b = (r + 1) * m.cols;
    for (int c = 0; c < m.cols; ++c) {
      if (r % 2 == 0) {
        if (c + 1 < m.cols) m.triangles.push_back({a + c, a + c + 1, b + c});
        if (c + 1 < m.cols) m.triangles.push_back({a + c + 1, b + c + 1, b + c});
      } else {
        if (c + 1 < m.cols) m.triangles.push_back({a + c, b + c + 1, b + c});
        if (c + 1 < m.cols) m.triangles.push_back({a + c, a + c + 1, b + c + 1});
      }
    }
  }
  return m;
}

Result<ChargedModel> build_charged_on_mesh(const SurfaceMesh& surface, const ChargedMaterialDef& material,
                                           const std::string& where, const TissueServices& services) {
  const Eigen::Index nv = surface.V.rows();
  if (nv < 3 || surface.F.rows() < 1)
    return Error{where + ": surface has " + std::to_string(nv) + " vertices and " +
                 std::to_string(surface.F.rows()) + " triangles; expected at least one triangle"};
  for (Eigen::Index i = 0; i < nv; ++i)
    if (!surface.V.row(i).allFinite())
      return Error{where + ": vertex " + std::to_string(i) + " has a non-finite coordinate"};
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (surface.F(f, k) < 0 || surface.F(f, k) >= nv)
        return Error{where + ": triangle " + std::to_string(f) + " refers to vertex " +
                     std::to_string(surface.F(f, k)) + "; expected an index in [0, " +
                     std::to_string(nv) + ")"};
  const double s = material.mesh_spacing;
  if (!(std::isfinite(s) && s > 0))
    return Error{where + ": material 'mesh_spacing' is " + num(s) + " m; expected a finite value > 0"};
  const Vec3 lo = surface.V.colwise().minCoeff(), hi = surface.V.colwise().maxCoeff();
  const double extent = (hi - lo).maxCoeff();
  if (extent / s > 2e4)
    return Error{where + ": material 'mesh_spacing' (" + num(s) + " m) is too fine for a surface " +
                 num(extent) + " m across; expected at most 20000 particles along it"};
  if (Result<double> st = check_material(material, 0.0, where); !st) return st.error();
  // What the patch laid at this spacing will take, refused before it is built: the surface's area
  // over a hexagonal lattice cell (s² √3/2), about 300 bytes a particle at the peak of building
  // (as a generated patch's estimate at load). A surface 1 m across at 50 µm passed the check
  // along it above and would have been 4.6e8 particles.
  double area = 0;
  for (Eigen::Index f = 0; f < surface.F.rows(); ++f) {
    const Vec3 a = surface.V.row(surface.F(f, 0)).transpose();
    area += 0.5 * (surface.V.row(surface.F(f, 1)).transpose() - a).cross(surface.V.row(surface.F(f, 2)).transpose() - a).norm();
  }
  const double particles = area / (s * s * 0.8660254037844386);
  const double need = particles * 300.0, memory = usable_memory_bytes();
  if (particles > double(kMaxParticles) || (memory > 0 && need > memory))
    return Error{where + ": material 'mesh_spacing' (" + num(s) + " m) lays about " + num(particles) +
                 " particles on the surface's " + num(area) + " m², about " + memory_text(need) +
                 " to build, more than " + (particles > double(kMaxParticles) ? std::string("the model's index range (") +
                 std::to_string(kMaxParticles) + " particles)" : "this machine's " + memory_text(memory) + " of memory") +
                 "; expected a coarser mesh_spacing"};

  if (!services.remesh) return Error{where + ": no remesher was handed to the tissue's builder (laying particles on a mesh needs one)"};
  Result<SurfaceMesh> remeshed = services.remesh(surface, s, where);
  if (!remeshed) return remeshed.error();
  const SurfaceMesh& r = *remeshed;
  const size_t n = static_cast<size_t>(r.V.rows());
  if (n > kMaxParticles) return Error{where + ": too many particles (" + std::to_string(n) + ")"};

  // Edges, each once, then at most six neighbours per particle: a vertex of valence > 6 drops its
  // longest edges (on both ends, so the relation stays symmetric) until six remain.
  std::vector<std::vector<int>> adj(n);
  for (Eigen::Index f = 0; f < r.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = r.F(f, k), b = r.F(f, (k + 1) % 3);
      adj[static_cast<size_t>(a)].push_back(b);
      adj[static_cast<size_t>(b)].push_back(a);
    }
  auto len = [&](int a, int b) { return (r.V.row(a) - r.V.row(b)).norm(); };
  for (size_t i = 0; i < n; ++i) {
    auto& a = adj[i];
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  for (size_t i = 0; i < n; ++i) {
    auto& a = adj[i];
    while (a.size() > 6) {
      auto far = std::max_element(a.begin(), a.end(), [&](int p, int q) {
        const double lp = len(static_cast<int>(i), p), lq = len(static_cast<int>(i), q);
        return lp < lq || (lp == lq && p < q);
      });
      const int j = *far;
      a.erase(far);
      auto& b = adj[static_cast<size_t>(j)];
      b.erase(std::find(b.begin(), b.end(), static_cast<int>(i)));
    }
  }

  // Remeshed edges are about [4/5, 4/3] of the target: max_separation must clear the longest kept.
  double longest = 0;
  for (size_t i = 0; i < n; ++i)
    for (int j : adj[i]) longest = std::max(longest, len(static_cast<int>(i), j));
  // With max_strain the limit is taken from the longest kept edge, so every edge satisfies it at rest.
  Result<double> separation = check_material(material, longest, where);
  if (!separation) return separation.error();

  ChargedModel m;
  m.material = material;
  set_force_model(m);
  m.layout = ChargedLayout::mesh;
  m.spacing = s;
  m.max_separation = *separation;
  // Cell grid over the origins, cells as wide as the reach of a thin tool (particle radius plus
  // maximum displacement plus a spacing), so a query visits few cells; a thicker tool visits more.
  m.cell_size = material.particle_radius + material.max_displacement + s;
  m.grid_min = r.V.colwise().minCoeff().transpose() - Vec3::Constant(0.5 * m.cell_size);
  const Vec3 gmax = r.V.colwise().maxCoeff().transpose() + Vec3::Constant(0.5 * m.cell_size);
  for (int k = 0; k < 3; ++k)
    m.grid_dims[static_cast<size_t>(k)] =
        static_cast<std::int64_t>(std::floor((gmax[k] - m.grid_min[k]) / m.cell_size)) + 1;
  auto key_of = [&](const Vec3& p) {
    std::array<std::int64_t, 3> c{};
    for (int k = 0; k < 3; ++k)
      c[static_cast<size_t>(k)] = std::clamp<std::int64_t>(
          static_cast<std::int64_t>(std::floor((p[k] - m.grid_min[k]) / m.cell_size)), 0,
          m.grid_dims[static_cast<size_t>(k)] - 1);
    return (c[2] * m.grid_dims[1] + c[1]) * m.grid_dims[0] + c[0];
  };
  std::vector<std::int64_t> keys(n);
  for (size_t i = 0; i < n; ++i) keys[i] = key_of(r.V.row(static_cast<Eigen::Index>(i)).transpose());
  std::vector<int> order(n);  // new index → remeshed vertex, sorted by cell (stable: deterministic)
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return keys[static_cast<size_t>(a)] < keys[static_cast<size_t>(b)];
  });
  std::vector<int> rank(n);
  for (size_t k = 0; k < n; ++k) rank[static_cast<size_t>(order[k])] = static_cast<int>(k);

  m.origin_x.resize(n), m.origin_y.resize(n), m.origin_z.resize(n);
  m.normal_x.resize(n), m.normal_y.resize(n), m.normal_z.resize(n);
  m.neighbours.assign(6 * n, -1);
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Index v = order[k];
    m.origin_x[k] = static_cast<float>(r.V(v, 0));
    m.origin_y[k] = static_cast<float>(r.V(v, 1));
    m.origin_z[k] = static_cast<float>(r.V(v, 2));
    Vec3 nrm = r.N.row(v).transpose();
    nrm = nrm.norm() > 0 ? nrm.normalized() : Vec3::UnitY();
    m.normal_x[k] = snorm16(nrm.x()), m.normal_y[k] = snorm16(nrm.y()), m.normal_z[k] = snorm16(nrm.z());
    std::vector<int> nb;
    for (int j : adj[static_cast<size_t>(v)]) nb.push_back(rank[static_cast<size_t>(j)]);
    std::sort(nb.begin(), nb.end());
    for (size_t j = 0; j < nb.size(); ++j) m.neighbours[6 * k + j] = nb[j];
    const std::int64_t key = keys[static_cast<size_t>(v)];
    if (m.cell_key.empty() || m.cell_key.back() != key) {
      m.cell_key.push_back(key);
      m.cell_start.push_back(static_cast<std::int32_t>(k));
    }
  }
  m.cell_start.push_back(static_cast<std::int32_t>(n));
  m.triangles.reserve(static_cast<size_t>(r.F.rows()));
  for (Eigen::Index f = 0; f < r.F.rows(); ++f)
    m.triangles.push_back({rank[static_cast<size_t>(r.F(f, 0))], rank[static_cast<size_t>(r.F(f, 1))],
                           rank[static_cast<size_t>(r.F(f, 2))]});
  return m;
}

ChargedState make_charged_state(const ChargedModel& model) {
  ChargedState s;
  fill_state_arrays(model, s);
  reset(model, s);
  return s;
}

void reset(const ChargedModel& model, ChargedState& s) noexcept {
  const size_t n = model.size();
  std::copy_n(model.origin_x.data(), n, s.x.data());
  std::copy_n(model.origin_y.data(), n, s.y.data());
  std::copy_n(model.origin_z.data(), n, s.z.data());
  std::fill(s.flags.begin(), s.flags.end(), std::uint8_t{0});
  s.active_count = 0;
  s.holes.fill(ChargedHole{});
  s.next_hole = 0;
  s.force = Vec3::Zero();
  s.contact_peak = 0;
  s.give = Vec3::Zero();
  s.give_age = 0;
  s.engaged = false;
  s.side = 1;
  const long resets = s.stats.numeric_resets;
  s.stats = ChargedStepStats{};
  s.stats.numeric_resets = resets;
  s.event_head = s.event_count = 0;
  s.events_dropped = 0;
  // Cuts stay: each wound edge is put where its opening has reached, and eases on from there with
  // the state's clock (which restarts at 0).
  for (size_t w = 0; w < s.wound_count; ++w) {
    ChargedWound& wd = s.wound[w];
    const double age = std::max(0.0, s.time - wd.since), f = std::exp(-model.material.elasticity * age);
    for (int k = 0; k < 3; ++k) wd.from[k] = static_cast<float>(wd.to[k] + (wd.from[k] - wd.to[k]) * f);
    wd.since = 0;
    const auto i = static_cast<size_t>(wd.particle);
    s.x[i] = model.origin_x[i] + wd.from[0], s.y[i] = model.origin_y[i] + wd.from[1],
    s.z[i] = model.origin_z[i] + wd.from[2];
    s.flags[i] |= 1u | 8u;  // active, on a wound's edge: it follows its easing offset
    s.active[s.active_count++] = wd.particle;
  }
  s.time = 0;
  s.blade_valid = false;
  s.cut_stroke = false;
  s.cut_bristle = Vec3::Zero();
}

void clear_cuts(const ChargedModel& model, ChargedState& s) noexcept {
  std::fill(s.cut.begin(), s.cut.end(), std::uint8_t{0});
  std::fill(s.wound_index.begin(), s.wound_index.end(), -1);
  s.wound_count = 0;
  s.wound_full = 0;
  s.cut_link_count = 0;
  reset(model, s);
}

size_t charged_bytes_per_particle(const ChargedModel& m) {
  size_t model_bytes = 3 * sizeof(float) + 3 * sizeof(std::int16_t);            // origin, normal
  if (m.layout == ChargedLayout::mesh) model_bytes += 6 * sizeof(std::int32_t);  // neighbours
  // Positions, flags, the two scratch indices and the cut mask. The wound table (ChargedWound and
  // its index, at most kChargedMaxWound entries) and the cutting scratch are cold: read only for
  // particles on a wound's edge or while a blade cuts.
  const size_t state_bytes = 3 * sizeof(float) + 2 * sizeof(std::uint8_t) + 2 * sizeof(std::int32_t);
  return model_bytes + state_bytes;  // lattice 40, mesh 64
}

}  // namespace palpate
