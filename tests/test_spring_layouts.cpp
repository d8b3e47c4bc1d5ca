// test_spring_layouts.cpp — SpringModel::solver, the opaque holder of the solvers' layouts
// (src/tissue/spring/layouts.h): a copied model owns layouts of its own with the same contents,
// and steps bit for bit as the model it was copied from.
#include "spring_fixtures.h"

#include "tissue/spring/layouts.h"

#include <gtest/gtest.h>

#include <utility>

using namespace palpate;
using namespace spring_test;

TEST(SpringLayouts, ACopiedModelOwnsEqualLayoutsAndStepsIdentically) {
  for (bool single : {false, true}) {
    SpringModelOptions o;
    o.solver = SpringSolver::sparse;
    o.single_precision = single;
    const SpringModel model = must_build(block_network(6, 6, 6, 0.005, 200.0, 0.1, true, 0.05), o);
    ASSERT_FALSE(model.solver->supernodes.empty());
    SpringModel copy = model;
    // A deep copy: other storage, the same values.
    EXPECT_NE(&*copy.solver, &*model.solver);
    EXPECT_EQ(copy.solver->supernodes.first_column, model.solver->supernodes.first_column);
    EXPECT_EQ(copy.solver->supernodes.chunk_rows, model.solver->supernodes.chunk_rows);
    EXPECT_TRUE(copy.solver->supernodes.values == model.solver->supernodes.values);
    EXPECT_TRUE(copy.solver->supernodes.values_single == model.solver->supernodes.values_single);
    // Moved, it keeps the layouts (no copy), and stepping the copy equals stepping the original.
    const spring::SolverLayouts* held = &*copy.solver;
    SpringModel moved = std::move(copy);
    EXPECT_EQ(&*moved.solver, held);
    SpringState a = make_state(model), b = make_state(moved);
    ToolState tool;
    tool.tip = Vec3(0.0125, 0.0285, 0.0125);
    tool.radius = 0.004;
    for (int i = 0; i < 40; ++i) {
      tool.tip.y() -= 2e-5;
      ASSERT_TRUE(step(model, a, &tool));
      ASSERT_TRUE(step(moved, b, &tool));
    }
    EXPECT_GT(max_displacement(model, a), 0.0) << "single " << single;
    EXPECT_EQ((a.x - b.x).cwiseAbs().maxCoeff(), 0.0) << "single " << single;
    EXPECT_EQ((a.v - b.v).cwiseAbs().maxCoeff(), 0.0) << "single " << single;
    EXPECT_EQ(a.tool_force, b.tool_force);
  }
}
