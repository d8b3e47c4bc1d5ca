// test_components.cpp — the optional components (OSMesa, Gmsh, CGAL): what palpate says it was built
// with, and, in a build without one (`make minimal-test`), the clear error each function that needs
// it gives instead of a crash or an empty result: the same Result error path, naming the option.
#include <palpate/meshing.h>
#include <palpate/mesh_load.h>
#include <palpate/render.h>
#include <palpate/run.h>
#include <palpate/scene.h>
#include <palpate/simulation.h>

#include "components.h"
#include "mesh_test_files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace {

// Skips a test of the error a build without COMPONENT gives, in a build with it.
#define PALPATE_WITHOUT(COMPONENT, name)                                                    \
  do {                                                                                      \
    if (PALPATE_HAS_##COMPONENT) GTEST_SKIP() << "built with " name ": nothing to refuse"; \
  } while (0)

const std::string kNoGmsh = ": palpate was built without Gmsh (cmake -DPALPATE_WITH_GMSH=ON): ";
const std::string kNoCgal = ": palpate was built without CGAL (cmake -DPALPATE_WITH_CGAL=ON): ";
const std::string kNoOsmesa = ": palpate was built without OSMesa (cmake -DPALPATE_WITH_OSMESA=ON): ";

palpate::RenderScene small_scene() {
  palpate::RenderScene s;
  s.camera.position = palpate::Vec3(0, 0, 1);
  s.camera.target = palpate::Vec3::Zero();
  s.camera.width = 32;
  s.camera.height = 24;
  return s;
}

}  // namespace

TEST(Components, TheLibrarySaysWhatItWasBuiltWith) {
  const std::string c = palpate::components();
  EXPECT_NE(c.find(PALPATE_HAS_OSMESA ? "OSMesa yes" : "OSMesa no"), std::string::npos) << c;
  EXPECT_NE(c.find(PALPATE_HAS_GMSH ? "Gmsh yes" : "Gmsh no"), std::string::npos) << c;
  EXPECT_NE(c.find(PALPATE_HAS_CGAL ? "CGAL yes" : "CGAL no"), std::string::npos) << c;
}

TEST(WithoutGmsh, ReadingAMshFileNamesTheOption) {
  PALPATE_WITHOUT(GMSH, "Gmsh");
  const std::filesystem::path file = palpate::test::data_mesh("liver.msh");
  const auto mesh = palpate::load_tet(file);
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.error().message, file.string() + kNoGmsh +
                                      "cannot read a Gmsh .msh mesh (TetGen .node/.ele and VTK .vtk meshes read without it)");
  // The other tetrahedral formats are palpate's own readers: the same liver reads without Gmsh.
  const auto vtk = palpate::load_tet(palpate::test::data_mesh("liver_tet.vtk"));
  ASSERT_TRUE(vtk.ok()) << vtk.error().message;
  EXPECT_EQ(vtk->T.rows(), 596);
}

TEST(WithoutGmsh, AMalformedMshFileStillGetsItsOwnError) {
  PALPATE_WITHOUT(GMSH, "Gmsh");
  const auto path = std::filesystem::temp_directory_path() / "palpate_components_bad.msh";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("Merge \"x.geo\";\n", f);  // not a .msh file: palpate's own check refuses it first
    std::fclose(f);
  }
  const auto mesh = palpate::load_tet(path);
  std::filesystem::remove(path);
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.error().message.find("built without Gmsh"), std::string::npos) << mesh.error().message;
  EXPECT_NE(mesh.error().message.find(path.string()), std::string::npos) << mesh.error().message;
}

TEST(WithoutGmsh, FillingASurfaceNamesTheOption) {
  PALPATE_WITHOUT(GMSH, "Gmsh");
  const auto tets = palpate::tetrahedralize(palpate::test::cube_surface(), 0.4);
  ASSERT_FALSE(tets.ok());
  EXPECT_EQ(tets.error().message, "tetrahedralize" + kNoGmsh + "cannot fill a surface with tetrahedra");
  // The options and the surface are still checked first, as with Gmsh.
  const auto bad = palpate::tetrahedralize(palpate::test::cube_surface(), -1.0);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("max_edge is -1"), std::string::npos) << bad.error().message;
}

TEST(WithoutGmsh, ASceneWithAMshTissueFailsToBuildNamingTheOption) {
  PALPATE_WITHOUT(GMSH, "Gmsh");
  const auto scene = palpate::load_scene(PALPATE_DATA_DIR "/scenes/liver-springs.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const auto sim = palpate::Simulation::build(*scene);
  ASSERT_FALSE(sim.ok());
  EXPECT_NE(sim.error().message.find("liver.msh" + kNoGmsh + "cannot read a Gmsh .msh mesh"), std::string::npos)
      << sim.error().message;
}

TEST(WithoutCgal, RemeshingNamesTheOption) {
  PALPATE_WITHOUT(CGAL, "CGAL");
  const auto r = palpate::remesh_isotropic(palpate::test::cube_surface(), 0.2, "tissue 'skin'");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "tissue 'skin'" + kNoCgal + "cannot remesh a surface isotropically (to lay particles on it)");
}

TEST(WithoutOsmesa, DrawingNamesTheOptionAndWritesNoFile) {
  PALPATE_WITHOUT(OSMESA, "OSMesa");
  const auto image = palpate::render_rgba(small_scene());
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.error().message, "render" + kNoOsmesa + "cannot draw off-screen (frames, images)");
  const auto png = std::filesystem::temp_directory_path() / "palpate_components_frame.png";
  std::filesystem::remove(png);
  const palpate::Status s = palpate::render_png(small_scene(), png);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message, png.string() + ": render" + kNoOsmesa + "cannot draw off-screen (frames, images)");
  EXPECT_FALSE(std::filesystem::exists(png));
  // A bad scene is still refused for what is wrong with it, as with OSMesa.
  palpate::RenderScene bad = small_scene();
  bad.camera.width = 0;
  const auto refused = palpate::render_rgba(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("render: camera size 0 x 24"), std::string::npos) << refused.error().message;
  // Where a point lands is plain camera math: the same without OSMesa.
  const auto centre = palpate::project_to_pixel(small_scene().camera, palpate::Vec3::Zero());
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->x(), 16, 1e-9);
  EXPECT_NEAR(centre->y(), 12, 1e-9);
}

TEST(WithoutOsmesa, ARunWithFramesRunsAndSaysWhyTheFramesAreMissing) {
  PALPATE_WITHOUT(OSMESA, "OSMesa");
  auto scene = palpate::load_scene(PALPATE_DATA_DIR "/scenes/default.yaml");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  scene->duration = 0.05;
  palpate::RunOptions o;
  o.out = std::filesystem::temp_directory_path() / "palpate_components_run";
  o.frames = 2;
  o.plots = false;
  const auto run = palpate::run_scene(*scene, o);
  std::filesystem::remove_all(o.out);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_TRUE(run->frames.empty());
  EXPECT_NE(run->frame_error.find(kNoOsmesa), std::string::npos) << run->frame_error;
}
