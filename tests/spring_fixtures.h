// spring_fixtures.h — networks and models shared by the mass-spring tests.
#pragma once

#include <palpate/spring.h>

#include "tissue/spring/shapes.h"

#include <gtest/gtest.h>

namespace spring_test {

using namespace palpate;

// A block of nx·ny·nz vertices, `spacing` apart, springs on its tet edges; the y = 0 layer
// anchored when `anchor_bottom`.
inline SpringNetwork block_network(int nx, int ny, int nz, double spacing, double stiffness, double total_mass,
                                   bool anchor_bottom, double spring_damping = 0.0) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.stiffness = stiffness;
  o.mass = total_mass;
  o.spring_damping = spring_damping;
  if (anchor_bottom)
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) o.anchors.push_back(i + nx * (0 + ny * k));
  auto net = make_spring_network(spring::make_block(nx, ny, nz, spacing), o, "block");
  EXPECT_TRUE(net.ok()) << net.error().message;
  return std::move(*net);
}

// Which vertices of a tet block are held: its lowest y layer, its highest, both, or none.
enum class Held { none, bottom, top, bottom_and_top };

// Tissue of Young's modulus E (5 kPa unless given) on a tet mesh, as the stiffness, volume,
// contact and damping tests set it up: springs on its tet edges, the volume term when ν > 0,
// masses lumped from `density`, the `held` layers anchored (in vertex order).
inline SpringNetworkOptions tissue_options(const TetMesh& mesh, double nu, double density, double spring_damping,
                                           Held held, double E = 5000) {
  SpringNetworkOptions o;
  o.topology = SpringTopology::tet_edges;
  o.youngs_modulus = E;
  o.poisson_ratio = nu;
  o.density = density;
  o.spring_damping = spring_damping;
  const double bottom = mesh.V.col(1).minCoeff(), top = mesh.V.col(1).maxCoeff();
  const bool low = held == Held::bottom || held == Held::bottom_and_top;
  const bool high = held == Held::top || held == Held::bottom_and_top;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if ((low && mesh.V(i, 1) < bottom + 1e-9) || (high && mesh.V(i, 1) > top - 1e-9))
      o.anchors.push_back(static_cast<int>(i));
  return o;
}

inline SpringNetwork tissue_network(const TetMesh& mesh, double nu, double density, double spring_damping, Held held,
                                    double E = 5000) {
  auto net = make_spring_network(mesh, tissue_options(mesh, nu, density, spring_damping, held, E), "block");
  EXPECT_TRUE(net.ok()) << net.error().message;
  return std::move(*net);
}

inline SpringModel must_build(SpringNetwork net, const SpringModelOptions& o) {
  auto m = build_spring_model(std::move(net), o);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return std::move(*m);
}

}  // namespace spring_test
