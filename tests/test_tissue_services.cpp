// test_tissue_services.cpp — a tissue model reads and meshes only through the TissueServices its
// builder hands in (DESIGN.md §3: tissue never calls io or meshing): an in-memory mesh serves a
// scene whose mesh file does not exist, a missing service is an error naming what was asked for,
// and a predictor goes through the services' reader and writer.
#include <palpate/spring.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "components.h"
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

namespace {

using namespace palpate;

// A closed octahedron, 20 mm across, outward triangles: small enough that every model builds fast.
SurfaceMesh octahedron() {
  SurfaceMesh m;
  m.V.resize(6, 3);
  m.V << 0.01, 0, 0, -0.01, 0, 0, 0, 0.01, 0, 0, -0.01, 0, 0, 0, 0.01, 0, 0, -0.01;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  compute_normals(m);
  return m;
}

int surface_calls = 0, fill_calls = 0;
std::map<std::string, std::string> stored;  // the predictor "files" the services keep in memory

Result<SurfaceMesh> memory_surface(const std::filesystem::path&, double scale, const SurfaceRequirements&) {
  ++surface_calls;
  SurfaceMesh m = octahedron();
  m.V *= scale;
  return m;
}
Result<TetMesh> counting_fill(const SurfaceMesh& s, const FillOptions& o) {
  ++fill_calls;
  return file_tissue_services().fill(s, o);
}
Result<StoredPredictor> memory_read(const std::filesystem::path& file) {
  StoredPredictor s;
  const auto it = stored.find(file.string());
  if (it == stored.end()) {
    s.why = file.string() + ": not stored";
  } else {
    s.present = true;
    s.payload = it->second;
  }
  return s;
}
Status memory_write(const std::filesystem::path& file, std::string_view bytes) {
  stored[file.string()] = std::string(bytes);
  return {};
}

SceneDef spring_scene(const std::string& topology) {
  SceneDef scene;
  scene.file = "/nonexistent/dir/scene.yaml";
  TissueDef t;
  t.name = "organ";
  t.model = "mass_spring";
  t.line = 7;
  t.mesh = MeshRef{.file = "/nonexistent/dir/organ.obj"};
  t.spring.topology = topology;
  t.spring.solver = "desbrun";
  t.spring.stiffness = 100;
  t.spring.predictor = "/nonexistent/dir/organ.predictor";
  scene.tissues.push_back(t);
  return scene;
}

TEST(TissueServices, AModelBuildsFromTheMeshItsBuilderHandsInNotFromTheFile) {
  PALPATE_NEEDS(GMSH, "Gmsh");
  surface_calls = fill_calls = 0;
  stored.clear();
  TissueServices s;
  s.load_surface = &memory_surface;
  s.fill = &counting_fill;
  s.read_predictor = &memory_read;
  s.write_predictor = &memory_write;
  // The mesh file does not exist: only the service's octahedron can have built it.
  auto first = make_tissue(spring_scene("tet_edges"), 0, s);
  ASSERT_TRUE(first) << first.error().message;
  EXPECT_EQ(surface_calls, 1);
  EXPECT_EQ(fill_calls, 1);
  TissueSnapshot snap;
  (*first)->snapshot(snap);
  EXPECT_GE(snap.points.size(), 6u);  // the octahedron's vertices, and the fill's
  // The predictor was computed and handed to the writer, under the scene's path; nothing on disk.
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored.begin()->first, "/nonexistent/dir/organ.predictor");
  EXPECT_FALSE(std::filesystem::exists("/nonexistent/dir"));
}

TEST(TissueServices, AMissingServiceIsAnErrorNamingWhatTheSceneAskedFor) {
  const TissueServices none;
  auto surface = make_tissue(spring_scene("edges"), 0, none);
  ASSERT_FALSE(surface);
  EXPECT_NE(surface.error().message.find("organ.obj: no surface loader was handed to the tissue's builder"),
            std::string::npos) << surface.error().message;

  TissueServices loads_only;
  loads_only.load_surface = &memory_surface;
  auto filled = make_tissue(spring_scene("tet_edges"), 0, loads_only);
  ASSERT_FALSE(filled);
  EXPECT_NE(filled.error().message.find("no tetrahedral mesher was handed"), std::string::npos) << filled.error().message;

  SceneDef charged;
  charged.file = "scene.yaml";
  TissueDef t;
  t.name = "skin";
  t.model = "charged_particles";
  t.mesh = MeshRef{.file = "skin.obj"};
  t.charged.mesh_spacing = 0.004;
  charged.tissues.push_back(t);
  auto remesh = make_tissue(charged, 0, loads_only);
  ASSERT_FALSE(remesh);
  EXPECT_NE(remesh.error().message.find("no remesher was handed"), std::string::npos) << remesh.error().message;
}

TEST(TissueServices, AStoredPredictorIsLoadedThroughTheReaderAndADamagedOneRecomputed) {
  surface_calls = fill_calls = 0;
  stored.clear();
  TissueServices s;
  s.load_surface = &memory_surface;
  s.read_predictor = &memory_read;
  s.write_predictor = &memory_write;
  const SceneDef scene = spring_scene("edges");
  auto setup = spring_setup(scene, 0, s);
  ASSERT_TRUE(setup) << setup.error().message;
  // Nowhere on disk: the model asks the services' store only.
  const std::filesystem::path file = "/nonexistent/dir/services.predictor";
  std::string note;
  auto computed = build_spring_model(setup->network, setup->options, file, PredictorPolicy::load_or_compute, s, &note);
  ASSERT_TRUE(computed) << computed.error().message;
  EXPECT_NE(note.find("saved"), std::string::npos) << note;
  ASSERT_EQ(stored.count(file.string()), 1u);
  EXPECT_FALSE(std::filesystem::exists(file.parent_path()));  // the writer kept it, not the disk
  auto loaded = build_spring_model(setup->network, setup->options, file, PredictorPolicy::require_file, s, &note);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(note, "loaded " + file.string());
  EXPECT_EQ(loaded->predictor.inverse, computed->predictor.inverse);
  stored[file.string()][20] ^= 0x10;  // damage a byte of the payload's parameters
  auto again = build_spring_model(setup->network, setup->options, file, PredictorPolicy::load_or_compute, s, &note);
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_NE(note.find("computed ("), std::string::npos) << note;
}

}  // namespace
