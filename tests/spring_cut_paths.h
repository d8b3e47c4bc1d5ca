// spring_cut_paths.h — random blade paths through a mass-spring block, shared by the test
// (test_spring_cut_paths.cpp) and the fuzz target (fuzz/fuzz_spring_cut.cpp): the bytes say how the
// hand moves the blade — drifting, plunging, turning, teleporting, losing its pose — and the block is
// cut as a scene's would be (SpringCutter + BladeCut, src/tissue/spring/). What a path must never
// do: leave a non-finite value, an open or non-manifold drawn surface, a tetrahedron inverted by
// the cut, or a predictor that is not exact to the cut network.
#pragma once

#include <palpate/spring.h>

#include "tissue/spring/blade.h"
#include "tissue/spring/stages.h"
#include "tissue/spring/shapes.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <utility>
#include <vector>

namespace palpate::cut_paths {

// A 5 x 5 x 5 block (2 mm spacing, 8 mm cube, its base held) of 50 kPa tissue with the volume term.
inline SpringModel block_model(SpringSolver solver = SpringSolver::sparse) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.youngs_modulus = 50000;
  o.poisson_ratio = 0.4;
  o.density = 1000;
  o.spring_damping = 0.02;
  const TetMesh mesh = spring::make_block(5, 5, 5, 0.002);
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (mesh.V(i, 1) < 1e-9) o.anchors.push_back(static_cast<int>(i));
  auto net = make_spring_network(mesh, o, "block");
  SpringModelOptions so;
  so.solver = solver;
  so.contact_stiffness = 2000;
  auto model = build_spring_model(std::move(*net), so);
  return std::move(*model);
}

struct PathReport {
  bool finite = true;          // every position and force finite
  int open_edges = 0;          // drawn edges without exactly one face each way
  int inverted = 0;            // live tetrahedra with volume <= 0
  int springs_cut = 0;
  std::uint64_t jumps = 0;
  double residual = 0;         // step vs a predictor built for the cut network (when asked)
  double backward = 0;         // the corrected solve's relative residual on the cut network's matrix
};

// Drive the blade along `data` (8 bytes a segment) through a copy of `base`.
inline PathReport run_blade_path(const SpringModel& base, const std::uint8_t* data, size_t size, bool check_exact,
                                 double cutting_force = 0.05) {
  PathReport r;
  SpringModel model = base;  // (a deep copy: the cut changes it)
  SpringCutOptions co;
  co.fixed_latency = 2;
  co.refactor_rank = 24;  // small: paths cross new factors often
  co.max_rank = 200;
  auto cutter = SpringCutter::create(model, co);
  if (!cutter) return r;
  spring::BladeSettings bs;
  bs.cutting_force = cutting_force;  // low by default: most paths cut
  spring::BladeCut blade(model, **cutter, bs);
  SpringState s = make_state(model);
  ToolState tool;
  tool.blade = true;
  tool.length = 0.006;
  tool.radius = 0.0005;
  tool.axis = Vec3(0, -1, 0);
  Vec3 tip(0.004, 0.0095, 0.004);
  const double dt = model.options.dt;
  auto unit = [](std::uint8_t b) { return (static_cast<double>(b) - 127.5) / 127.5; };
  for (size_t at = 0; at + 8 <= size; at += 8) {
    const std::uint8_t* b = data + at;
    const Vec3 v = 0.03 * Vec3(unit(b[0]), unit(b[1]), unit(b[2]));  // up to 30 mm/s each way
    Vec3 axis = Vec3(0.5 * unit(b[3]), -1.0, 0.5 * unit(b[4])).normalized();
    const int ticks = 1 + b[5] % 40;
    const std::uint8_t flags = b[6];
    const bool press = flags & 1, teleport = flags & 2, lost = flags & 4, no_edge = flags & 8;
    for (int k = 0; k < ticks; ++k) {
      Vec3 vel = v;
      if (press) vel += 0.02 * (Vec3(0.004, 0.004, 0.004) - tip).normalized();
      tip += vel * dt;
      tip = tip.cwiseMax(Vec3::Constant(-0.004)).cwiseMin(Vec3::Constant(0.014));  // near the block
      tool.tip = tip;
      tool.axis = axis;
      tool.velocity = vel;
      tool.length = no_edge ? 0.0 : 0.006;
      if (teleport && k == 0) tool.tip = tip + Vec3(0.03, 0, 0);
      if (lost && k == 0) tool.tip = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      tool.time += dt;
      (*cutter)->install();
      blade.cut(s, tool, dt);
      const bool ok = step(model, s, tool.tip.allFinite() ? &tool : nullptr);
      const Vec3 f = blade.felt(ok ? s.tool_force : Vec3::Zero(), tool, dt);
      if (!f.allFinite() || !s.x.allFinite() || !s.v.allFinite()) r.finite = false;
    }
  }
  r.springs_cut = (*cutter)->status().removed_springs;
  r.jumps = blade.jumps();
  // The drawn surface: every edge once each way.
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : model.network.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}];
  for (const auto& [e, count] : directed) {
    const auto back = directed.find({e.second, e.first});
    if (count != 1 || back == directed.end() || back->second != 1) ++r.open_edges;
  }
  // The live tetrahedra where the path left them: none turned inside out.
  const auto& gone = (*cutter)->removed_tets();
  for (size_t t = 0; t < base.network.tets.size(); ++t) {
    if (gone[t]) continue;
    const auto& T = base.network.tets[t];
    const Vec3 a = s.x.row(T[0]).transpose();
    const double v6 = (Vec3(s.x.row(T[1]).transpose()) - a)
                          .cross(Vec3(s.x.row(T[2]).transpose()) - a)
                          .dot(Vec3(s.x.row(T[3]).transpose()) - a);
    if (!(v6 > 0)) ++r.inverted;
  }
  if (check_exact) {
    (*cutter)->settle();
    SpringNetwork net = base.network;
    const auto& cut = (*cutter)->removed_springs();
    for (size_t e = 0; e < cut.size(); ++e)
      if (cut[e]) net.stiffness[e] = net.damping[e] = 0;
    net.tets.clear();
    net.rest_volume.clear();
    for (size_t t = 0; t < gone.size(); ++t)
      if (!gone[t]) {
        net.tets.push_back(base.network.tets[t]);
        net.rest_volume.push_back(base.network.rest_volume[t]);
      }
    auto ref = build_spring_model(std::move(net), base.options);
    if (!ref) return r;
    SpringState a = make_state(model), c = make_state(*ref);
    a.x = c.x = s.x;
    a.v = c.v = s.v;
    step(model, a, nullptr);
    step(*ref, c, nullptr);
    const RowMat3d da = a.v - s.v, dc = c.v - s.v;
    // The relative residual of the solve the step uses (the cut model's factor and its installed
    // correction) on the cut network's own matrix A' = M + h(γI + C_L) + h²K_L (anchored rows the
    // identity): ‖A' x̂ − b‖∞ / (‖A'‖∞ ‖x̂‖∞ + ‖b‖∞) for b = A' x, x a fixed spread of values.
    {
      const SpringNetwork& N = model.network;
      const double h = model.options.dt, g = model.options.point_damping;
      const Eigen::Index nv = static_cast<Eigen::Index>(N.size());
      std::vector<double> diag(N.size()), rowsum(N.size(), 0.0);
      for (size_t i = 0; i < N.size(); ++i) diag[i] = N.mass[i] + h * g;
      for (size_t e = 0; e < N.springs.size(); ++e) {
        const double w = h * N.damping[e] + h * h * model.predictor_stiffness[e];
        diag[static_cast<size_t>(N.springs[e][0])] += w;
        diag[static_cast<size_t>(N.springs[e][1])] += w;
      }
      const auto apply = [&](const RowMat3d& x, RowMat3d& y) {
        for (Eigen::Index i = 0; i < nv; ++i)
          y.row(i) = (model.anchored[static_cast<size_t>(i)] ? 1.0 : diag[static_cast<size_t>(i)]) * x.row(i);
        for (size_t e = 0; e < N.springs.size(); ++e) {
          const int i = N.springs[e][0], j = N.springs[e][1];
          if (model.anchored[static_cast<size_t>(i)] || model.anchored[static_cast<size_t>(j)]) continue;
          const double w = h * N.damping[e] + h * h * model.predictor_stiffness[e];
          y.row(i) -= w * x.row(j);
          y.row(j) -= w * x.row(i);
        }
      };
      double norm_a = 0;
      for (Eigen::Index i = 0; i < nv; ++i) rowsum[static_cast<size_t>(i)] = model.anchored[static_cast<size_t>(i)] ? 1.0 : diag[static_cast<size_t>(i)];
      for (size_t e = 0; e < N.springs.size(); ++e) {
        const int i = N.springs[e][0], j = N.springs[e][1];
        if (model.anchored[static_cast<size_t>(i)] || model.anchored[static_cast<size_t>(j)]) continue;
        const double w = std::abs(h * N.damping[e] + h * h * model.predictor_stiffness[e]);
        rowsum[static_cast<size_t>(i)] += w;
        rowsum[static_cast<size_t>(j)] += w;
      }
      for (double v : rowsum) norm_a = std::max(norm_a, v);
      RowMat3d x(nv, 3), b(nv, 3), xh(nv, 3), ax(nv, 3);
      for (Eigen::Index i = 0; i < nv; ++i)
        for (int k = 0; k < 3; ++k) x(i, k) = std::sin(1.0 + 3.7 * static_cast<double>(i) + 1.3 * k);
      apply(x, b);
      SpringState w = make_state(model);
      spring::solve_predictor(model, w, b, xh);
      apply(xh, ax);
      r.backward = (ax - b).cwiseAbs().maxCoeff() / (norm_a * xh.cwiseAbs().maxCoeff() + b.cwiseAbs().maxCoeff());
    }
    const double scale = dc.cwiseAbs().maxCoeff();
    r.residual = scale > 0 ? (da - dc).cwiseAbs().maxCoeff() / scale : (da - dc).cwiseAbs().maxCoeff();
  }
  return r;
}

}  // namespace palpate::cut_paths
