// test_predictor_paths.cpp — a predictor path that is not a regular file (a directory, a FIFO) is
// refused when the organ is built, naming the path and what it is, under either policy; the FIFO is
// left as it was (not computed around and renamed over), and nothing blocks opening it.
#include <palpate/tissue_files.h>
#include "spring_fixtures.h"

#include "simulation/predictor_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

using namespace palpate;
using namespace spring_test;

TEST(PredictorPaths, ADirectoryOrAFifoIsRefusedUnderEitherPolicy) {
  const SpringNetwork net = block_network(3, 3, 3, 0.01, 300.0, 0.1, true, 0.05);
  SpringModelOptions o;
  o.solver = SpringSolver::sparse;
  const auto dir = std::filesystem::temp_directory_path() / ("palpate_predictor_paths_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "a_directory");
  const auto fifo = dir / "a.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (PredictorPolicy policy : {PredictorPolicy::load_or_compute, PredictorPolicy::require_file}) {
    auto d = build_spring_model(net, o, dir / "a_directory", policy);
    ASSERT_FALSE(d.ok());
    EXPECT_EQ(d.error().message, (dir / "a_directory").string() +
                                     ": is a directory, not a regular file; expected a palpate predictor file "
                                     "(material.predictor)");
    auto f = build_spring_model(net, o, fifo, policy);
    ASSERT_FALSE(f.ok());
    EXPECT_NE(f.error().message.find("is a FIFO (named pipe), not a regular file"), std::string::npos)
        << f.error().message;
    EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  }
  std::filesystem::remove_all(dir);
}
