// step.cpp — the per-tick kernels of the mass-spring model: forces, the predictor solve
// (Desbrun, Schröder & Barr 1999), the angular-momentum correction, tool contact and grasping,
// and the exact backward-Euler reference (Newton).
#include <palpate/spring.h>

#include <Eigen/SparseCholesky>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

namespace palpate {

namespace {

using RowMatXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Internal spring forces (Hooke about the rest length plus a damper along the spring):
//   f_i += [k_e (l − L_e) + c_e (v_j − v_i)·u] u,  f_j −= the same,  u = (x_j − x_i)/l.
// x, v, f are (n x 3); f is added to.
void add_spring_forces(const SpringNetwork& net, const RowMat3d& x, const RowMat3d& v, RowMat3d& f) noexcept {
  const size_t s = net.springs.size();
  for (size_t e = 0; e < s; ++e) {
    const int i = net.springs[e][0], j = net.springs[e][1];
    const double dx = x(j, 0) - x(i, 0), dy = x(j, 1) - x(i, 1), dz = x(j, 2) - x(i, 2);
    const double l = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(l > 0)) continue;
    const double inv_l = 1.0 / l;
    const double dvu = ((v(j, 0) - v(i, 0)) * dx + (v(j, 1) - v(i, 1)) * dy + (v(j, 2) - v(i, 2)) * dz) * inv_l;
    const double g = (net.stiffness[e] * (l - net.rest_length[e]) + net.damping[e] * dvu) * inv_l;
    f(i, 0) += g * dx; f(i, 1) += g * dy; f(i, 2) += g * dz;
    f(j, 0) -= g * dx; f(j, 1) -= g * dy; f(j, 2) -= g * dz;
  }
}

// The same for every pair (the seed paper's topology), on structure-of-arrays copies so that the
// inner loop over j > i is contiguous and vectorised by Eigen. soa is (10n): x, y, z, vx, vy, vz,
// fx, fy, fz and g, each n long.
void add_all_pair_forces(const SpringNetwork& net, const RowMat3d& x, const RowMat3d& v, RowMat3d& f,
                         std::vector<double>& soa) noexcept {
  const Eigen::Index n = x.rows();
  using Arr = Eigen::Map<Eigen::ArrayXd>;
  double* p = soa.data();
  Arr X(p, n), Y(p + n, n), Z(p + 2 * n, n), VX(p + 3 * n, n), VY(p + 4 * n, n), VZ(p + 5 * n, n);
  Arr FX(p + 6 * n, n), FY(p + 7 * n, n), FZ(p + 8 * n, n);
  X = x.col(0).array(); Y = x.col(1).array(); Z = x.col(2).array();
  VX = v.col(0).array(); VY = v.col(1).array(); VZ = v.col(2).array();
  FX.setZero(); FY.setZero(); FZ.setZero();
  Eigen::Index e0 = 0;
  for (Eigen::Index i = 0; i + 1 < n; ++i) {
    const Eigen::Index m = n - 1 - i;
    const auto dx = X.segment(i + 1, m) - X[i];
    const auto dy = Y.segment(i + 1, m) - Y[i];
    const auto dz = Z.segment(i + 1, m) - Z[i];
    const Eigen::Map<const Eigen::ArrayXd> L(net.rest_length.data() + e0, m), K(net.stiffness.data() + e0, m),
        C(net.damping.data() + e0, m);
    Arr G(p + 9 * n, m);
    // g = [k (l − L) l + c (Δv·d)] / l²; coincident vertices (l = 0) get g = 0 through the max.
    G = (K * ((dx * dx + dy * dy + dz * dz).sqrt() - L) * (dx * dx + dy * dy + dz * dz).sqrt() +
         C * ((VX.segment(i + 1, m) - VX[i]) * dx + (VY.segment(i + 1, m) - VY[i]) * dy +
              (VZ.segment(i + 1, m) - VZ[i]) * dz)) /
        (dx * dx + dy * dy + dz * dz).max(1e-300);
    FX[i] += (G * dx).sum();
    FY[i] += (G * dy).sum();
    FZ[i] += (G * dz).sum();
    FX.segment(i + 1, m) -= G * dx;
    FY.segment(i + 1, m) -= G * dy;
    FZ.segment(i + 1, m) -= G * dz;
    e0 += m;
  }
  f.col(0).array() += FX; f.col(1).array() += FY; f.col(2).array() += FZ;
}

Vec3 gravity_vector(const SpringModelOptions& o) {
  return o.gravity ? Vec3(0, -o.gravity_acceleration, 0) : Vec3::Zero();
}

// Forces from the tool, added to f (n x 3), and their reaction on the tool.
// Probe: a penalty on every vertex inside the sphere (tip, radius), f = k_c (r − |x − tip|) n̂ minus a
// normal damper, k_c clamped to max_contact_stiffness so the explicit penalty stays stable.
// Grasp: vertices within radius + grasp_radius when the grasp starts follow the tool on springs.
Vec3 add_tool_forces(const SpringModel& model, SpringState& s, const ToolState& tool, RowMat3d& f) noexcept {
  const SpringModelOptions& o = model.options;
  const Eigen::Index n = s.x.rows();
  Vec3 on_tool = Vec3::Zero();
  s.contacts = 0;
  const double r = std::max(tool.radius, 0.0);
  if (tool.grasp && !s.grasping) {
    // Grab the nearest vertices within reach (at most kMaxGrasped), nearest first.
    s.grasped_count = 0;
    const double reach = r + o.grasp_radius;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (model.anchored[static_cast<size_t>(i)]) continue;
      const double d = (s.x.row(i).transpose() - tool.tip).norm();
      if (d > reach) continue;
      int slot = s.grasped_count;
      if (slot == SpringState::kMaxGrasped) {
        // Replace the farthest if this one is nearer.
        int far = 0;
        double far_d = -1;
        for (int k = 0; k < slot; ++k) {
          const double dk = (s.x.row(s.grasped[static_cast<size_t>(k)]).transpose() - tool.tip).norm();
          if (dk > far_d) { far_d = dk; far = k; }
        }
        if (far_d <= d) continue;
        slot = far;
      } else {
        ++s.grasped_count;
      }
      s.grasped[static_cast<size_t>(slot)] = static_cast<int>(i);
      s.grasp_offset[static_cast<size_t>(slot)] = s.x.row(i).transpose() - tool.tip;
    }
    s.grasping = true;
  } else if (!tool.grasp) {
    s.grasping = false;
    s.grasped_count = 0;
  }
  for (int k = 0; k < s.grasped_count; ++k) {
    const int i = s.grasped[static_cast<size_t>(k)];
    const double kg = std::min(o.grasp_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const Vec3 target = tool.tip + s.grasp_offset[static_cast<size_t>(k)];
    const Vec3 fi = kg * (target - s.x.row(i).transpose());
    f.row(i) += fi.transpose();
    on_tool -= fi;
  }
  if (r <= 0 || o.contact_stiffness <= 0) return on_tool;
  const double r2 = r * r;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vec3 d = s.x.row(i).transpose() - tool.tip;
    const double d2 = d.squaredNorm();
    if (d2 >= r2 || model.anchored[static_cast<size_t>(i)]) continue;
    const double dist = std::sqrt(d2);
    const Vec3 normal = dist > 1e-12 * r ? Vec3(d / dist) : Vec3(-tool.axis.normalized());
    const double kc = std::min(o.contact_stiffness, model.max_contact_stiffness[static_cast<size_t>(i)]);
    const double approach = (s.v.row(i).transpose() - tool.velocity).dot(normal);
    const double magnitude = std::max(0.0, kc * (r - dist) - o.contact_damping * approach);
    const Vec3 fi = magnitude * normal;
    f.row(i) += fi.transpose();
    on_tool -= fi;
    ++s.contacts;
  }
  return on_tool;
}

// External and point-damping-free forces: gravity, then the tool. Returns the force on the tool.
Vec3 external_forces(const SpringModel& model, SpringState& s, const ToolState* tool, RowMat3d& f) noexcept {
  const Vec3 g = gravity_vector(model.options);
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) f.row(i) = (model.network.mass[static_cast<size_t>(i)] * g).transpose();
  return tool ? add_tool_forces(model, s, *tool, f) : Vec3::Zero();
}

// Δv = A⁻¹ b with the dense inverse: three dot products per row of A⁻¹ (b is (n x 3)).
void apply_dense(const SpringPredictor& p, const RowMat3d& b, RowMat3d& dv, RowMat3d& work) noexcept {
  const Eigen::Index n = p.n;
  // Columns of b contiguous for the dot products.
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::ColMajor>> bc(work.data(), n, 3);
  bc = b;
  const Eigen::Map<const RowMatXd> W(p.inverse.data(), n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto w = W.row(i);
    dv(i, 0) = w.dot(bc.col(0).transpose());
    dv(i, 1) = w.dot(bc.col(1).transpose());
    dv(i, 2) = w.dot(bc.col(2).transpose());
  }
}

// Δv = A⁻¹ b with A = Pᵀ L D Lᵀ P: permute, forward substitution, scale, back substitution,
// permute back. The three coordinates are solved together (interleaved), sharing L.
void apply_sparse(const SpringPredictor& p, const RowMat3d& b, RowMat3d& dv, RowMat3d& z) noexcept {
  const int n = p.n;
  for (int i = 0; i < n; ++i) z.row(p.perm[static_cast<size_t>(i)]) = b.row(i);
  double* zd = z.data();
  const int* cs = p.col_start.data();
  const int* rw = p.row.data();
  const double* lv = p.value.data();
  for (int c = 0; c < n; ++c) {
    const double z0 = zd[3 * c], z1 = zd[3 * c + 1], z2 = zd[3 * c + 2];
    for (int q = cs[c]; q < cs[c + 1]; ++q) {
      double* t = zd + 3 * rw[q];
      const double l = lv[q];
      t[0] -= l * z0; t[1] -= l * z1; t[2] -= l * z2;
    }
  }
  for (int c = 0; c < n; ++c) {
    const double d = p.inv_diag[static_cast<size_t>(c)];
    zd[3 * c] *= d; zd[3 * c + 1] *= d; zd[3 * c + 2] *= d;
  }
  for (int c = n - 1; c >= 0; --c) {
    double a0 = zd[3 * c], a1 = zd[3 * c + 1], a2 = zd[3 * c + 2];
    for (int q = cs[c]; q < cs[c + 1]; ++q) {
      const double* t = zd + 3 * rw[q];
      const double l = lv[q];
      a0 -= l * t[0]; a1 -= l * t[1]; a2 -= l * t[2];
    }
    zd[3 * c] = a0; zd[3 * c + 1] = a1; zd[3 * c + 2] = a2;
  }
  for (int i = 0; i < n; ++i) dv.row(i) = z.row(p.perm[static_cast<size_t>(i)]);
}

// The post-step correction for the dropped non-linear part (DS99 §4.3): spring forces are
// central, so they must not change the angular momentum; the predictor's transverse stiffness
// (K_L ⊗ I3 instead of the true k uuᵀ) does. The spurious change
//   δL = Σ m_i x_i × Δv_i − h (τ_ext + Σ x_i × (−γ v_i⁺))
// (τ_ext = Σ x_i × f_ext,i, about the origin) is removed by a rigid angular velocity ω = I⁺ δL,
// I the inertia tensor about the centre of mass c: Δv_i −= ω × (x_i − c). Linear momentum is
// unchanged since Σ m_i (x_i − c) = 0. Free bodies only: anchors exert torques implicitly.
void correct_angular_momentum(const SpringModel& model, const SpringState& s, const Vec3& ext_torque,
                              RowMat3d& dv) noexcept {
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  Vec3 c = Vec3::Zero();
  for (Eigen::Index i = 0; i < n; ++i) c += model.network.mass[static_cast<size_t>(i)] * s.x.row(i).transpose();
  c /= model.total_mass;
  Vec3 delta = -h * ext_torque;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double m = model.network.mass[static_cast<size_t>(i)];
    const Vec3 xi = s.x.row(i).transpose();
    const Vec3 dvi = dv.row(i).transpose();
    const Vec3 v_new = s.v.row(i).transpose() + dvi;
    delta += xi.cross(m * dvi + h * gamma * v_new);
    const Vec3 r = xi - c;
    inertia += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  // Pseudo-inverse: a collinear body has no inertia about its own axis.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
  const double top = eig.eigenvalues().maxCoeff();
  if (!(top > 0)) return;
  Vec3 w = eig.eigenvectors().transpose() * delta;
  for (int k = 0; k < 3; ++k) w[k] = eig.eigenvalues()[k] > 1e-12 * top ? w[k] / eig.eigenvalues()[k] : 0.0;
  const Vec3 omega = eig.eigenvectors() * w;
  for (Eigen::Index i = 0; i < n; ++i) dv.row(i) -= omega.cross(s.x.row(i).transpose() - c).transpose();
}

// Force of the organ on its anchors: everything acting on the anchored vertices (springs, their
// weight). f_all is the total force (n x 3) at the start of the step.
Vec3 anchor_load(const SpringModel& model, const RowMat3d& f_all) noexcept {
  Vec3 sum = Vec3::Zero();
  for (int a : model.network.anchors) sum += f_all.row(a).transpose();
  return sum;
}

bool finite_and_slow(const SpringModel& model, const SpringState& s) noexcept {
  const double vmax2 = model.options.max_speed * model.options.max_speed;
  const Eigen::Index n = s.x.rows();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double v2 = s.v.row(i).squaredNorm();
    if (!(v2 <= vmax2) || !std::isfinite(s.x(i, 0) + s.x(i, 1) + s.x(i, 2))) return false;
  }
  return true;
}

void all_forces(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  s.tool_force = external_forces(model, s, tool, s.work);
  s.force = s.work;
  if (model.all_pairs) add_all_pair_forces(model.network, s.x, s.v, s.force, s.soa);
  else add_spring_forces(model.network, s.x, s.v, s.force);
  s.anchor_force = anchor_load(model, s.force);
}

// One step with the precomputed predictor (DS99): the implicit system with the constant matrix,
//   (M + h(γI + C_L) + h²K_L) Δv = h (f(x, v) − γ v − h K_L v),
// solved with the stored inverse or factor, then corrected, then x⁺ = x + h v⁺.
void step_predictor(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  const SpringNetwork& net = model.network;
  const double h = model.options.dt;
  const double gamma = model.options.point_damping;
  const Eigen::Index n = s.x.rows();
  all_forces(model, s, tool);  // s.work holds the external forces afterwards
  const bool correct = model.options.angular_momentum_correction && net.anchors.empty();
  Vec3 ext_torque = Vec3::Zero();
  if (correct)
    for (Eigen::Index i = 0; i < n; ++i) ext_torque += s.x.row(i).transpose().cross(s.work.row(i).transpose());
  s.rhs = s.force - gamma * s.v;
  for (size_t e = 0; e < net.springs.size(); ++e) {
    const int i = net.springs[e][0], j = net.springs[e][1];
    const double kh = h * net.stiffness[e];
    for (int c = 0; c < 3; ++c) {
      const double d = kh * (s.v(i, c) - s.v(j, c));
      s.rhs(i, c) -= d;
      s.rhs(j, c) += d;
    }
  }
  s.rhs *= h;
  for (int a : net.anchors) s.rhs.row(a).setZero();
  if (model.predictor.kind == SpringSolver::desbrun) apply_dense(model.predictor, s.rhs, s.dv, s.work);
  else apply_sparse(model.predictor, s.rhs, s.dv, s.work);
  if (correct) correct_angular_momentum(model, s, ext_torque, s.dv);
  s.v += s.dv;
  for (int a : net.anchors) s.v.row(a).setZero();
  s.x += h * s.v;
}

// The exact backward Euler: solve G(Δv) = M Δv − h f(x + h(v + Δv), v + Δv) = 0 by Newton with the
// full spring Jacobian, K_e = k [uuᵀ + max(0, 1 − L/l)(I − uuᵀ)] (the transverse term clamped at
// zero in compression keeps the matrix definite; the residual stays exact), re-assembled and
// factorised (SimplicialLDLT) every iteration. External and tool forces are taken at the start.
void step_exact(const SpringModel& model, SpringState& s, const ToolState* tool) {
  const SpringNetwork& net = model.network;
  const SpringModelOptions& o = model.options;
  const double h = o.dt, gamma = o.point_damping;
  const Eigen::Index n = s.x.rows();
  all_forces(model, s, tool);
  const RowMat3d f_ext = s.work;
  RowMat3d dv = RowMat3d::Zero(n, 3);
  RowMat3d xn(n, 3), vn(n, 3), f(n, 3);
  Eigen::VectorXd residual(3 * n);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<size_t>(3 * n + 36 * static_cast<Eigen::Index>(net.springs.size())));
  Eigen::SparseMatrix<double> J(3 * n, 3 * n);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  s.newton_iterations = 0;
  const double vscale = 1.0 + s.v.cwiseAbs().maxCoeff();
  for (int it = 0; it < o.newton_iterations; ++it) {
    vn = s.v + dv;
    xn = s.x + h * vn;
    f = f_ext - gamma * vn;
    add_spring_forces(net, xn, vn, f);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        residual[3 * i + c] = model.anchored[static_cast<size_t>(i)]
                                  ? dv(i, c)
                                  : net.mass[static_cast<size_t>(i)] * dv(i, c) - h * f(i, c);
    trip.clear();
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = model.anchored[static_cast<size_t>(i)] ? 1.0 : net.mass[static_cast<size_t>(i)] + h * gamma;
      for (int c = 0; c < 3; ++c) trip.emplace_back(3 * i + c, 3 * i + c, d);
    }
    for (size_t e = 0; e < net.springs.size(); ++e) {
      const int a = net.springs[e][0], b = net.springs[e][1];
      Vec3 d = (xn.row(b) - xn.row(a)).transpose();
      const double l = d.norm();
      if (!(l > 0)) continue;
      const Vec3 u = d / l;
      const Eigen::Matrix3d uu = u * u.transpose();
      const double lateral = std::max(0.0, 1.0 - net.rest_length[e] / l);
      const Eigen::Matrix3d B = h * h * net.stiffness[e] * (uu + lateral * (Eigen::Matrix3d::Identity() - uu)) +
                                h * net.damping[e] * uu;
      const bool fa = !model.anchored[static_cast<size_t>(a)], fb = !model.anchored[static_cast<size_t>(b)];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          if (fa) trip.emplace_back(3 * a + r, 3 * a + c, B(r, c));
          if (fb) trip.emplace_back(3 * b + r, 3 * b + c, B(r, c));
          if (fa && fb) {
            trip.emplace_back(3 * a + r, 3 * b + c, -B(r, c));
            trip.emplace_back(3 * b + r, 3 * a + c, -B(r, c));
          }
        }
    }
    J.setFromTriplets(trip.begin(), trip.end());
    if (it == 0) solver.analyzePattern(J);
    solver.factorize(J);
    if (solver.info() != Eigen::Success) break;
    const Eigen::VectorXd delta = solver.solve(residual);
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) dv(i, c) -= delta[3 * i + c];
    ++s.newton_iterations;
    if (delta.cwiseAbs().maxCoeff() <= o.newton_tolerance * vscale) break;
  }
  s.v += dv;
  for (int a : net.anchors) s.v.row(a).setZero();
  s.x += h * s.v;
}

}  // namespace

bool step(const SpringModel& model, SpringState& s, const ToolState* tool) noexcept {
  // A device glitch (non-finite pose) must not reach the tissue: the tool is ignored this step.
  if (tool && !(tool->tip.allFinite() && tool->velocity.allFinite() && tool->axis.allFinite() &&
                std::isfinite(tool->radius)))
    tool = nullptr;
  if (model.options.solver == SpringSolver::exact) {
    try {
      step_exact(model, s, tool);
    } catch (...) {  // out of memory in the reference solver: treated as a blow-up
      s.v.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  } else {
    step_predictor(model, s, tool);
  }
  s.time += model.options.dt;
  if (finite_and_slow(model, s)) return true;
  const std::uint64_t resets = s.resets + 1;
  reset(model, s);
  s.resets = resets;
  return false;
}

double kinetic_energy(const SpringModel& model, const SpringState& s) noexcept {
  double e = 0;
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) e += 0.5 * model.network.mass[static_cast<size_t>(i)] * s.v.row(i).squaredNorm();
  return e;
}

double elastic_energy(const SpringModel& model, const SpringState& s) noexcept {
  const SpringNetwork& net = model.network;
  double e = 0;
  for (size_t k = 0; k < net.springs.size(); ++k) {
    const double l = (s.x.row(net.springs[k][0]) - s.x.row(net.springs[k][1])).norm();
    e += 0.5 * net.stiffness[k] * (l - net.rest_length[k]) * (l - net.rest_length[k]);
  }
  return e;
}

Vec3 linear_momentum(const SpringModel& model, const SpringState& s) noexcept {
  Vec3 p = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i) p += model.network.mass[static_cast<size_t>(i)] * s.v.row(i).transpose();
  return p;
}

Vec3 angular_momentum(const SpringModel& model, const SpringState& s) noexcept {
  Vec3 l = Vec3::Zero();
  for (Eigen::Index i = 0; i < s.v.rows(); ++i)
    l += model.network.mass[static_cast<size_t>(i)] * s.x.row(i).transpose().cross(s.v.row(i).transpose());
  return l;
}

double max_displacement(const SpringModel& model, const SpringState& s) noexcept {
  double d2 = 0;
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) d2 = std::max(d2, (s.x.row(i) - model.network.rest.row(i)).squaredNorm());
  return std::sqrt(d2);
}

}  // namespace palpate
