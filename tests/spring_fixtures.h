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

inline SpringModel must_build(SpringNetwork net, const SpringModelOptions& o) {
  auto m = build_spring_model(std::move(net), o);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return std::move(*m);
}

}  // namespace spring_test
