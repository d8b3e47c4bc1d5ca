// components.h — the optional components palpate was built with (PALPATE_HAS_OSMESA, _GMSH, _CGAL:
// 1 or 0, from palpate::core; README, Building by hand). A test that needs one starts with
// PALPATE_NEEDS(GMSH, "Gmsh") and is skipped, naming it, in a build without it (`make minimal-test`);
// test_components.cpp checks the clear error such a build gives instead.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>

#define PALPATE_NEEDS(COMPONENT, name)                                                            \
  do {                                                                                            \
    if (!PALPATE_HAS_##COMPONENT)                                                                 \
      GTEST_SKIP() << "needs " name ": palpate was built without it (-DPALPATE_WITH_" #COMPONENT "=OFF)"; \
  } while (0)

// The palpate command's tests, in a build without it (PALPATE_BUILD_APPS=OFF: PALPATE_CLI is "").
#define PALPATE_NEEDS_CLI()                                                                       \
  do {                                                                                            \
    if (std::string_view(PALPATE_CLI).empty())                                                    \
      GTEST_SKIP() << "needs the palpate command: built without it (-DPALPATE_BUILD_APPS=OFF)";   \
  } while (0)

// The optional component a scene file needs and this build lacks, or "": Gmsh for a .msh mesh, CGAL
// for particles laid on a mesh (mesh_spacing). For tests that run every shipped scene.
inline std::string missing_component(const std::filesystem::path& scene) {
  std::ifstream in(scene);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!PALPATE_HAS_GMSH && text.find(".msh") != std::string::npos) return "Gmsh";
  if (!PALPATE_HAS_CGAL && text.find("mesh_spacing") != std::string::npos) return "CGAL";
  return "";
}
