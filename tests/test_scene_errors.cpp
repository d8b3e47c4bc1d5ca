// test_scene_errors.cpp — the scene loader's errors: one test per kind of bad input with its exact
// text, missing and irregular files, the example scenes, and docs/scene-format.md kept in step with
// the tables.
#include "scene_fixtures.h"

#include <nlohmann/json.hpp>

using namespace palpate;
using namespace scene_test;

TEST(SceneErrors, UnknownKeySuggestsTheClosestAndListsValidKeys) {
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    material:\n      max_displacment: 0.01\n"),
            "s.yaml:5: tissues[0].material.max_displacment: unknown key (did you mean 'max_displacement'?); "
            "valid charged_particles material keys: max_displacement, elasticity, particle_radius, "
            "max_strain, max_separation, puncture_force, linear_share, snap_share, puncture_time, hole_closes, "
            "two_sided, thickness, friction_per_length, friction_presliding, cutting_force, cutting_drag_per_length, "
            "wound_gap, mesh_spacing, force_model, "
            "particle_charge, hip_charge");
  // A key of the model before its force became a law of the indentation says what replaced it.
  const std::string old = error_of("tissues:\n  - name: a\n    patch: {}\n    material:\n      sphere_of_influence: 0.002\n");
  EXPECT_EQ(old.substr(0, old.find("; valid")),
            "s.yaml:5: tissues[0].material.sphere_of_influence: unknown key; 'sphere_of_influence' is now the "
            "tool's radius plus 'particle_radius'");
  // Far from every key: no suggestion; section keys are listed with the table's.
  EXPECT_EQ(error_of(std::string("colour: red\n") + kOneTissue),
            "s.yaml:1: colour: unknown key; valid scene keys: name, duration, dt, output, tool, device, camera, "
            "anatomy, probe, grasper, tissues");
  EXPECT_EQ(error_of(std::string("tool: {radus: 0.002}\n") + kOneTissue).substr(0, 57),
            "s.yaml:1: tool.radus: unknown key (did you mean 'radius'?");
}

TEST(SceneErrors, UnknownMaterialKeyOfTheOtherModelSaysSo) {
  const std::string e = error_of(
      "tissues:\n  - name: a\n    model: mass_spring\n    patch: {}\n    material: {puncture_force: 2}\n");
  EXPECT_EQ(e.substr(0, e.find("; valid")),
            "s.yaml:5: tissues[0].material.puncture_force: unknown key; 'puncture_force' is a "
            "charged_particles key");
  EXPECT_NE(e.find("valid mass_spring material keys: topology, solver,"), std::string::npos) << e;
}

TEST(SceneErrors, MissingRequiredKeys) {
  EXPECT_EQ(error_of("name: x\nduration: 2\n"),
            "s.yaml:1: tissues: missing; expected a list of tissues, or an 'anatomy' that generates them");
  EXPECT_EQ(error_of("tissues:\n  - model: mass_spring\n    patch: {}\n"),
            "s.yaml:2: tissues[0]: missing required key 'name'");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    mesh:\n      scale: 2\n"),
            "s.yaml:4: tissues[0].mesh: missing required key 'file'");
  EXPECT_EQ(error_of(std::string("device:\n  waypoints:\n    - {t: 0}\n") + kOneTissue),
            "s.yaml:3: device.waypoints[0]: missing required key 'position'");
  EXPECT_EQ(error_of(std::string("device: {kind: replay}\n") + kOneTissue),
            "s.yaml:1: device: missing required key 'recording' (kind is 'replay')");
}

TEST(SceneErrors, WrongTypeNamesWhatWasExpected) {
  EXPECT_EQ(error_of(std::string("tool:\n  radius: abc\n") + kOneTissue),
            "s.yaml:2: tool.radius: expected a number (m), got 'abc'");
  EXPECT_EQ(error_of(std::string("duration: [1, 2]\n") + kOneTissue),
            "s.yaml:1: duration: expected a number (s), got a list of 2");
  EXPECT_EQ(error_of(std::string("camera: {width: 2.5}\n") + kOneTissue),
            "s.yaml:1: camera.width: expected an integer (pixels), got '2.5'");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    material: {hole_closes: maybe}\n"),
            "s.yaml:4: tissues[0].material.hole_closes: expected true or false, got 'maybe'");
  EXPECT_EQ(error_of(std::string("name: {a: 1}\n") + kOneTissue), "s.yaml:1: name: expected a string, got a mapping");
  EXPECT_EQ(error_of(std::string("tool: 3\n") + kOneTissue),
            "s.yaml:1: tool: expected a mapping of tool keys, got '3'");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    anchors: [1, x]\n"),
            "s.yaml:4: tissues[0].anchors[1]: expected an integer, got 'x'");
  EXPECT_EQ(error_of("tissues: {name: a}\n"), "s.yaml:1: tissues: expected a non-empty list of tissues, got a mapping");
  EXPECT_EQ(error_of("tissues: []\n"), "s.yaml:1: tissues: expected a non-empty list of tissues, got a list of 0");
  EXPECT_EQ(error_of(std::string("duration:\n") + kOneTissue), "s.yaml:1: duration: expected a number (s), got nothing");
  EXPECT_EQ(error_of(std::string("tool:\n") + kOneTissue), "s.yaml:1: tool: expected a mapping of tool keys, got nothing");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch:\n"),
            "s.yaml:3: tissues[0].patch: expected a mapping of patch keys, got nothing");
}

TEST(SceneErrors, OutOfRangeGivesTheRangeAndUnit) {
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    material:\n      max_displacement: 5\n"),
            "s.yaml:5: tissues[0].material.max_displacement: 5 m is out of range; expected [1e-06, 1] m");
  EXPECT_EQ(error_of(std::string("duration: 7200\n") + kOneTissue),
            "s.yaml:1: duration: 7200 s is out of range; expected [1e-05, 3600] s");
  EXPECT_EQ(error_of(std::string("camera:\n  height: 4\n") + kOneTissue),
            "s.yaml:2: camera.height: 4 pixels is out of range; expected an integer in [16, 16384] pixels");
  EXPECT_EQ(error_of(std::string("tool: {axis: [0, -3, 0]}\n") + kOneTissue),
            "s.yaml:1: tool.axis[1]: -3 is out of range; expected [-1, 1]");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    anchors: [-1]\n"),
            "s.yaml:4: tissues[0].anchors[0]: -1 is out of range; expected an integer in [0, 2147483647]");
}

TEST(SceneErrors, StringNotAmongChoicesListsThem) {
  EXPECT_EQ(error_of(std::string("tool: {kind: scalpel}\n") + kOneTissue),
            "s.yaml:1: tool.kind: 'scalpel' is not one of: sphere, needle, blade");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    model: fem\n    patch: {}\n"),
            "s.yaml:3: tissues[0].model: 'fem' is not one of: charged_particles, mass_spring");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    model: mass_spring\n    patch: {}\n    material:\n"
                     "      solver: cg\n"),
            "s.yaml:6: tissues[0].material.solver: 'cg' is not one of: desbrun, sparse, exact");
  // A prefix or a joined pair of choices is not a choice.
  EXPECT_EQ(error_of(std::string("tool: {kind: 'sphere|needle'}\n") + kOneTissue),
            "s.yaml:1: tool.kind: 'sphere|needle' is not one of: sphere, needle, blade");
  EXPECT_EQ(error_of(std::string("tool: {kind: sph}\n") + kOneTissue),
            "s.yaml:1: tool.kind: 'sph' is not one of: sphere, needle, blade");
}

TEST(SceneErrors, VectorMustBeThreeNumbers) {
  EXPECT_EQ(error_of(std::string("tool:\n  axis: [0, 1]\n") + kOneTissue),
            "s.yaml:2: tool.axis: expected 3 numbers [x, y, z], got a list of 2");
  EXPECT_EQ(error_of(std::string("camera:\n  target: 0.5\n") + kOneTissue),
            "s.yaml:2: camera.target: expected 3 numbers [x, y, z] (m), got '0.5'");
  EXPECT_EQ(error_of(std::string("camera:\n  target: [0, y, 0]\n") + kOneTissue),
            "s.yaml:2: camera.target[1]: expected a number (m), got 'y'");
  EXPECT_EQ(error_of(std::string("tool: {axis: [0, 0, 0]}\n") + kOneTissue),
            "s.yaml:1: tool.axis: expected a non-zero direction [x, y, z], got [0, 0, 0]");
}

TEST(SceneErrors, YamlSyntaxErrorGivesLine) {
  const std::string e = error_of("name: x\ntool:\n  radius: [0.1\n  kind: sphere\n");
  EXPECT_EQ(e.rfind("s.yaml:", 0), 0u) << e;
  EXPECT_NE(e.find(": YAML syntax error: "), std::string::npos) << e;
  EXPECT_NE(e.find("(column "), std::string::npos) << e;
  EXPECT_EQ(error_of("name: x\n  bad: indent\n").substr(0, 35), "s.yaml:2: YAML syntax error: illega");
  // A document that opens with a token no node starts with: yaml-cpp 0.7's LoadAll looped on it
  // until memory ran out (found by fuzz_scene); now an error naming the line and column.
  EXPECT_EQ(error_of(","), "s.yaml:1: YAML syntax error: ',' cannot start a document (column 1)");
  EXPECT_EQ(error_of("# a comment\n  , 1 mm spacing\n"),
            "s.yaml:2: YAML syntax error: ',' cannot start a document (column 3)");
}

TEST(SceneErrors, EmptyFileAndNonMappingTopLevel) {
  const std::string empty = "s.yaml: the scene is empty; expected a mapping with at least the key 'tissues'";
  EXPECT_EQ(error_of(""), empty);
  EXPECT_EQ(error_of("# only a comment\n\n"), empty);
  EXPECT_EQ(error_of("- a\n- b\n"), "s.yaml:1: expected a mapping of scene keys at the top level, got a list of 2");
  EXPECT_EQ(error_of(std::string(kOneTissue) + "---\nname: second\n"),
            "s.yaml:5: a second YAML document starts here; expected one scene per file");
  // A short key far from every valid one gets no suggestion.
  EXPECT_EQ(error_of(std::string("<<: {}\n") + kOneTissue),
            "s.yaml:1: <<: unknown key; valid scene keys: name, duration, dt, output, tool, device, camera, anatomy, "
            "probe, grasper, tissues");
  EXPECT_EQ(error_of("just text\n"),
            "s.yaml:1: expected a mapping of scene keys at the top level, got 'just text'");
}

TEST(SceneErrors, DuplicateTissueNamesAndDuplicateKeys) {
  EXPECT_EQ(error_of("tissues:\n  - name: skin\n    patch: {}\n  - name: skin\n    patch: {}\n"),
            "s.yaml:4: tissues[1].name: duplicate tissue name 'skin' (first on line 2)");
  EXPECT_EQ(error_of(std::string("dt: 0.001\ndt: 0.002\n") + kOneTissue),
            "s.yaml:2: dt: duplicate key (first on line 1)");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    anchors: [1, 2, 1]\n"),
            "s.yaml:4: tissues[0].anchors[2]: 1 is listed twice");
}

TEST(SceneErrors, ExactlyOneOfPatchAndMesh) {
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {}\n    mesh: {file: liver.msh}\n",
                     PALPATE_DATA_DIR "/meshes"),
            "s.yaml:4: tissues[0]: has both 'patch' and 'mesh'; expected exactly one");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n  - name: b\n    patch: {}\n"),
            "s.yaml:2: tissues[0]: has neither 'patch' nor 'mesh'; expected exactly one");
}

TEST(SceneErrors, WaypointTimesMustNotGoBack) {
  EXPECT_EQ(error_of(std::string("device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0]}\n"
                                 "    - {t: 2, position: [0, 0, 0]}\n    - {t: 1.5, position: [0, 0, 0]}\n") +
                     kOneTissue),
            "s.yaml:5: device.waypoints[2].t: time 1.5 s goes back (previous waypoint at 2 s); "
            "expected non-decreasing times");
  EXPECT_EQ(error_of(std::string("device:\n  kind: openhaptics\n  waypoints:\n    - {t: 0, position: [0, 0, 0]}\n") +
                     kOneTissue),
            "s.yaml:3: device.waypoints: only a scripted device follows waypoints (kind is 'openhaptics')");
}

TEST(Scene, WaypointDirectionsAreNormalisedAndOptional) {
  auto r = parse_scene(std::string("device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0]}\n"
                                   "    - {t: 1, position: [0, 0, 0], direction: [0, -0.5, 0.5]}\n"
                                   "    - {t: 2, position: [0, 0, 0]}\n") +
                           kOneTissue,
                       "s.yaml");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto& w = r->device.waypoints;
  ASSERT_EQ(w.size(), 3u);
  EXPECT_EQ(w[0].direction, Vec3::Zero());  // not given: the device keeps the previous (tool.axis)
  EXPECT_NEAR((w[1].direction - Vec3(0, -1, 1) / std::sqrt(2.0)).norm(), 0.0, 1e-15);
  EXPECT_EQ(w[2].direction, Vec3::Zero());
}

TEST(SceneErrors, WaypointDirectionMustBeANonZeroFiniteVector) {
  EXPECT_EQ(error_of(std::string("device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0]}\n"
                                 "    - {t: 1, position: [0, 0, 0],\n       direction: [0, 0, 0]}\n") +
                     kOneTissue),
            "s.yaml:5: device.waypoints[1].direction: expected a non-zero direction [x, y, z], got [0, 0, 0]");
  EXPECT_EQ(error_of(std::string("device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0], direction: [0, .nan, 1]}\n") +
                     kOneTissue),
            "s.yaml:3: device.waypoints[0].direction[1]: expected a finite number, got '.nan'");
  EXPECT_EQ(error_of(std::string("device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0], direction: [0, 1]}\n") +
                     kOneTissue),
            "s.yaml:3: device.waypoints[0].direction: expected 3 numbers [x, y, z], got a list of 2");
  EXPECT_EQ(error_of(std::string("device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0], diretcion: [0, 1, 0]}\n") +
                     kOneTissue),
            "s.yaml:3: device.waypoints[0].diretcion: unknown key (did you mean 'direction'?); valid waypoint "
            "keys: t, position, direction, grasp");
}

TEST(SceneErrors, NanAndInfinityAreRejected) {
  EXPECT_EQ(error_of(std::string("duration: .nan\n") + kOneTissue),
            "s.yaml:1: duration: expected a finite number (s), got '.nan'");
  EXPECT_EQ(error_of(std::string("tool: {radius: .inf}\n") + kOneTissue),
            "s.yaml:1: tool.radius: expected a finite number (m), got '.inf'");
  EXPECT_EQ(error_of(std::string("camera: {target: [0, -.inf, 0]}\n") + kOneTissue),
            "s.yaml:1: camera.target[1]: expected a finite number (m), got '-.inf'");
  EXPECT_EQ(error_of(std::string("dt: nan\n") + kOneTissue), "s.yaml:1: dt: expected a finite number (s), got 'nan'");
  EXPECT_EQ(error_of(std::string("duration: 1e400\n") + kOneTissue),
            "s.yaml:1: duration: expected a finite number (s), got '1e400'");
}

TEST(SceneErrors, CrossFieldChecks) {
  EXPECT_EQ(error_of(std::string("duration: 0.01\ndt: 0.05\n") + kOneTissue),
            "s.yaml:2: dt: 0.05 s exceeds duration 0.01 s; expected dt <= duration");
  EXPECT_EQ(error_of(std::string("tool:\n  kind: needle\n  length: 0\n") + kOneTissue),
            "s.yaml:3: tool.length: a needle needs a length > 0 m (its shaft), got 0 m");
  EXPECT_EQ(error_of(std::string("tool:\n  kind: blade\n  length: 0\n") + kOneTissue),
            "s.yaml:3: tool.length: a blade needs a length > 0 m (its cutting edge), got 0 m");
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch: {spacing: 0.002}\n    material:\n"
                     "      max_separation: 0.002\n"),
            "s.yaml:5: tissues[0].material.max_separation: 0.002 m must exceed the patch spacing 0.002 m "
            "(or leave it 0 and set max_strain)");
  // By default the separation limit follows the spacing (max_strain): any spacing is valid.
  EXPECT_TRUE(parse_scene("tissues:\n  - name: a\n    patch: {spacing: 0.002}\n", "s.yaml", kTestData).ok());
  // A mass-spring patch has no separation rule.
  EXPECT_TRUE(parse_scene("tissues:\n  - {name: a, model: mass_spring, patch: {spacing: 0.002}}\n", "s.yaml").ok());
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    patch:\n      spacing: 0.01\n      width: 0.005\n"),
            "s.yaml:5: tissues[0].patch.width: 0.005 m is less than the spacing 0.01 m; expected at least one "
            "spacing");
  EXPECT_EQ(error_of(std::string("camera: {position: [1, 1, 1], target: [1, 1, 1]}\n") + kOneTissue),
            "s.yaml:1: camera.target: must differ from camera.position");
  EXPECT_EQ(error_of(std::string("device:\n  trajectory: trajectory.csv\n  waypoints:\n"
                                 "    - {t: 0, position: [0, 0, 0]}\n") + kOneTissue),
            "s.yaml:2: device.trajectory: give either 'waypoints' or 'trajectory', not both");
}

TEST(SceneErrors, MissingInputFilesNameKeyAndResolvedPath) {
  const fs::path base = kTestData;
  EXPECT_EQ(error_of("tissues:\n  - name: a\n    mesh:\n      file: meshes/none.msh\n", base),
            "s.yaml:4: tissues[0].mesh.file: file not found: " + (base / "meshes/none.msh").string() +
                " (relative paths are resolved against " + base.string() + ")");
  EXPECT_EQ(error_of(std::string("device: {trajectory: gone.csv}\n") + kOneTissue, base),
            "s.yaml:1: device.trajectory: file not found: " + (base / "gone.csv").string() +
                " (relative paths are resolved against " + base.string() + ")");
  EXPECT_EQ(error_of(std::string("device: {kind: replay, recording: /nowhere/run.csv}\n") + kOneTissue, base),
            "s.yaml:1: device.recording: file not found: /nowhere/run.csv (relative paths are resolved against " +
                base.string() + ")");
  // Files that exist load, resolved against the base directory.
  auto ok = parse_scene(std::string("device: {trajectory: trajectory.csv}\n") + kOneTissue, "s.yaml", base);
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->device.trajectory, base / "trajectory.csv");
  auto replay = parse_scene(std::string("device: {kind: replay, recording: recording.csv}\n") + kOneTissue, "s.yaml", base);
  ASSERT_TRUE(replay.ok()) << replay.error().message;
  EXPECT_EQ(replay->device.recording, base / "recording.csv");
}

TEST(SceneLoad, MissingFileAndDirectory) {
  auto r = palpate::load_scene("/nonexistent/dir/scene.yaml");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "/nonexistent/dir/scene.yaml: no such file; expected a YAML scene file");
  auto d = palpate::load_scene(kTestData);
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.error().message, kTestData.string() + ": is a directory, not a regular file; expected a YAML scene file");
}

TEST(SceneLoad, ErrorsNameTheFileAsGiven) {
  const fs::path file = fs::temp_directory_path() / "palpate_test_scene_bad.yaml";
  {
    std::ofstream out(file);
    out << "name: x\ntissues:\n  - name: a\n    patch: {widht: 0.02}\n";
  }
  auto r = palpate::load_scene(file);
  fs::remove(file);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.substr(0, file.string().size() + 63),
            file.string() + ":4: tissues[0].patch.widht: unknown key (did you mean 'width'?)");
}

TEST(SceneExamples, EveryDataSceneLoads) {
  const fs::path dir = PALPATE_SOURCE_DIR "/data/scenes";
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    auto r = palpate::load_scene(entry.path());
    EXPECT_TRUE(r.ok()) << r.error().message;
    if (r.ok()) {
      EXPECT_TRUE(!r->tissues.empty() || r->anatomy.has_value());  // an anatomy's are generated at build
      EXPECT_EQ(r->file, entry.path());
    }
    names.insert(entry.path().filename().string());
  }
  for (const char* want : {"default.yaml", "probe.yaml", "liver-springs.yaml", "liver-probe.yaml"})
    EXPECT_TRUE(names.count(want)) << want << " missing from data/scenes";
}

TEST(SceneExamples, DefaultIsTheNeedleThroughThreeLayers) {
  auto r = palpate::load_scene(PALPATE_SOURCE_DIR "/data/scenes/default.yaml");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->tool.kind, "needle");
  EXPECT_EQ(r->tool.radius, 0.0004);
  EXPECT_EQ(r->tool.length, 0.08);
  EXPECT_EQ(r->duration, 4.0);
  ASSERT_EQ(r->tissues.size(), 3u);
  const double ys[] = {0.0, -0.004, -0.012};
  for (size_t i = 0; i < 3; ++i) {
    ASSERT_TRUE(r->tissues[i].patch.has_value());
    EXPECT_EQ(r->tissues[i].patch->center.y(), ys[i]) << r->tissues[i].name;
  }
  const auto& skin = r->tissues[0].charged;
  const auto& fat = r->tissues[1].charged;
  const auto& wall = r->tissues[2].charged;
  EXPECT_GE(skin.puncture_force, 1.5);
  EXPECT_LE(skin.puncture_force, 2.5);
  EXPECT_LT(fat.puncture_force, skin.puncture_force);
  EXPECT_GE(wall.puncture_force, 0.5);
  EXPECT_LE(wall.puncture_force, 1.0);
  // The needle starts above the skin, goes below the vessel wall, and comes back up.
  const auto& w = r->device.waypoints;
  ASSERT_GE(w.size(), 3u);
  EXPECT_EQ(w.front().position.y(), 0.01);
  EXPECT_EQ(w[1].t, 3.0);
  EXPECT_EQ(w[1].position.y(), -0.02);
  EXPECT_GT(w.back().position.y(), 0.0);
  EXPECT_EQ(w.back().t, 4.0);
  EXPECT_TRUE(r->camera.has_value());
}

TEST(SceneExamples, LiverScenesResolveToTheProjectsLiverMesh) {
  const fs::path liver = fs::weakly_canonical(PALPATE_DATA_DIR "/meshes/liver.msh");
  for (const char* name : {"liver-springs.yaml", "liver-probe.yaml"}) {
    auto r = palpate::load_scene(fs::path(PALPATE_SOURCE_DIR "/data/scenes") / name);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->tissues.size(), 1u);
    const auto& t = r->tissues[0];
    EXPECT_EQ(t.model, "mass_spring");
    ASSERT_TRUE(t.mesh.has_value());
    EXPECT_EQ(fs::weakly_canonical(t.mesh->file), liver) << name;
    EXPECT_EQ(t.spring.topology, "tet_edges");
  }
  auto sofa = palpate::load_scene(PALPATE_SOURCE_DIR "/data/scenes/liver-springs.yaml");
  ASSERT_TRUE(sofa.ok());
  EXPECT_EQ(sofa->tissues[0].mesh->scale, 1.0);
  EXPECT_EQ(sofa->tissues[0].spring.stiffness, 4500);
  EXPECT_EQ(sofa->tissues[0].spring.mass, 1.0);
  EXPECT_EQ(sofa->tissues[0].spring.solver, "sparse");
  EXPECT_EQ(sofa->tissues[0].anchors, (std::vector<int>{3, 39, 64}));  // SOFA's fixed nodes
  EXPECT_EQ(sofa->dt, 0.02);
  EXPECT_TRUE(sofa->tissues[0].spring.gravity);
  auto probe = palpate::load_scene(PALPATE_SOURCE_DIR "/data/scenes/liver-probe.yaml");
  ASSERT_TRUE(probe.ok());
  EXPECT_EQ(probe->tissues[0].mesh->scale, 0.01);
  EXPECT_EQ(probe->tool.kind, "sphere");
  EXPECT_EQ(probe->tissues[0].anchors.size(), 59u);  // its bed: the underside (test_liver_probe.cpp)
}

TEST(SceneReference, ListsEveryKeyWithItsDefault) {
  const std::string md = palpate::scene_reference_markdown();
  EXPECT_NE(md.find("| `dt` | number | s | `0.001` | [1e-05, 0.1] |  | "), std::string::npos);
  EXPECT_NE(md.find("| `kind` | string |  | `\"sphere\"` |  | `sphere, needle, blade` | "), std::string::npos);
  EXPECT_NE(md.find("| `axis` | [x, y, z] |  | `[0, -1, 0]` | [-1, 1] |"), std::string::npos);
  EXPECT_NE(md.find("| `name` | string |  | required |"), std::string::npos);
  EXPECT_NE(md.find("| `direction` | [x, y, z] |  | the previous waypoint's (`tool.axis` for the first) | [-1, 1] |"),
            std::string::npos);
  EXPECT_NE(md.find("| `tissues` | list of mappings |  |  |  |  | the tissues (section `tissues[]`); at least one, or an "
                    "`anatomy` |"),
            std::string::npos);
  EXPECT_NE(md.find("| `hole_closes` | bool |  | `false` |"), std::string::npos);
  EXPECT_NE(md.find("| `width` | integer | pixels | `800` | [16, 16384] |"), std::string::npos);
  // Every key of every table appears as a row.
  auto rows = [&](auto* def) {
    for (const auto& p : palpate::param_table(def))
      EXPECT_NE(md.find(std::string("| `") + p.key + "` |"), std::string::npos) << p.key;
  };
  rows(static_cast<const palpate::SceneDef*>(nullptr));
  rows(static_cast<const palpate::ChargedMaterialDef*>(nullptr));
  rows(static_cast<const palpate::SpringMaterialDef*>(nullptr));
  rows(static_cast<const palpate::MeshRef*>(nullptr));
}

TEST(SceneReference, DocContainsTheCurrentGeneratedReference) {
  const std::string doc = read_text(PALPATE_SOURCE_DIR "/docs/scene-format.md");
  const std::string begin = "<!-- reference:begin -->\n", end = "<!-- reference:end -->";
  const size_t b = doc.find(begin), e = doc.find(end);
  ASSERT_NE(b, std::string::npos);
  ASSERT_NE(e, std::string::npos);
  ASSERT_LT(b, e);
  EXPECT_EQ(doc.substr(b + begin.size(), e - b - begin.size()), palpate::scene_reference_markdown())
      << "docs/scene-format.md is out of date: run scripts/update-scene-reference";
}

TEST(SceneReference, ShippedSchemaIsTheCurrentGeneratedOne) {
  // data/schema/scene.schema.json is what `palpate schema` prints, from the same tables as the
  // parser: a table changed without regenerating it fails here.
  EXPECT_EQ(read_text(PALPATE_SOURCE_DIR "/data/schema/scene.schema.json"), palpate::scene_json_schema())
      << "data/schema/scene.schema.json is out of date: run scripts/update-scene-reference";
}

TEST(SceneReference, SchemaStatesEveryTableKeyWithItsRangeAndDefault) {
  // Against the tables: every key of a section is a property with its type, range, unit and
  // default; choices are an enum; required keys are required; a Vec3 is three numbers; the
  // material follows the tissue's model.
  const auto schema = nlohmann::json::parse(palpate::scene_json_schema());
  EXPECT_EQ(schema["$schema"], "https://json-schema.org/draft/2020-12/schema");
  const auto& defs = schema["$defs"];
  const auto& dt = schema["properties"]["dt"];
  EXPECT_EQ(dt["type"], "number");
  EXPECT_EQ(dt["minimum"], 1e-5);
  EXPECT_EQ(dt["maximum"], 0.1);
  EXPECT_EQ(dt["default"], 0.001);
  EXPECT_EQ(dt["x-unit"], "s");
  EXPECT_EQ(defs["tissue"]["properties"]["model"]["enum"], nlohmann::json::array({"charged_particles", "mass_spring"}));
  EXPECT_EQ(defs["waypoint"]["required"], nlohmann::json::array({"t", "position"}));
  EXPECT_EQ(defs["waypoint"]["properties"]["position"]["minItems"], 3);
  EXPECT_EQ(defs["waypoint"]["properties"]["position"]["maxItems"], 3);
  EXPECT_EQ(defs["tissue"]["if"]["properties"]["model"]["const"], "mass_spring");
  EXPECT_EQ(defs["tissue"]["then"]["properties"]["material"]["$ref"], "#/$defs/spring_material");
  EXPECT_EQ(defs["tissue"]["else"]["properties"]["material"]["$ref"], "#/$defs/charged_material");
  EXPECT_EQ(defs["spring_material"]["additionalProperties"], false);
  auto expect_table = [&](const auto* def, const nlohmann::json& props) {
    for (const auto& p : palpate::param_table(def)) {
      ASSERT_TRUE(props.contains(p.key)) << p.key;
      const auto& q = props[p.key];
      if (std::isfinite(p.min) && q["type"] == "number") {
        EXPECT_EQ(q["minimum"], p.min) << p.key;
      }
      if (std::isfinite(p.max) && q["type"] == "number") {
        EXPECT_EQ(q["maximum"], p.max) << p.key;
      }
      if (*p.unit) {
        EXPECT_EQ(q["x-unit"], p.unit) << p.key;
      }
    }
    size_t n = 0;
    for (const auto& p : palpate::param_table(def)) n += p.key != nullptr;
    EXPECT_GE(props.size(), n);
  };
  expect_table(static_cast<const palpate::SpringMaterialDef*>(nullptr), defs["spring_material"]["properties"]);
  expect_table(static_cast<const palpate::ChargedMaterialDef*>(nullptr), defs["charged_material"]["properties"]);
  expect_table(static_cast<const palpate::NeckDef*>(nullptr), defs["anatomy"]["properties"]);
  expect_table(static_cast<const palpate::DeviceDef*>(nullptr), defs["device"]["properties"]);
  // Defaults are the Defs' own: a spring's Poisson ratio, a patch's spacing.
  EXPECT_EQ(defs["spring_material"]["properties"]["poisson_ratio"]["default"], palpate::SpringMaterialDef{}.poisson_ratio);
  EXPECT_EQ(defs["patch"]["properties"]["spacing"]["default"], palpate::PatchDef{}.spacing);
}

TEST(SceneReference, DocExampleSceneParses) {
  const std::string doc = read_text(PALPATE_SOURCE_DIR "/docs/scene-format.md");
  const size_t b = doc.find("```yaml\n");
  ASSERT_NE(b, std::string::npos);
  const size_t e = doc.find("```", b + 8);
  ASSERT_NE(e, std::string::npos);
  auto r = parse_scene(doc.substr(b + 8, e - b - 8), "scene-format.md", PALPATE_SOURCE_DIR "/data/scenes");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_GE(r->tissues.size(), 2u);
}

// docs/haptics.md's table of device keys and the loader agree: every key it documents loads at its
// documented default, and every key the loader takes is documented there.
TEST(Scene, EveryDeviceKeyDocumentedInHapticsMdLoads) {
  std::ifstream doc(PALPATE_SOURCE_DIR "/docs/haptics.md");
  ASSERT_TRUE(doc.good());
  const auto rec = std::filesystem::temp_directory_path() / "palpate_doc_keys_run.csv";
  std::ofstream(rec) << "t,tool_x,tool_y,tool_z\n0,0,0,0\n";
  const auto traj = std::filesystem::temp_directory_path() / "palpate_doc_keys_traj.csv";
  std::ofstream(traj) << "0,0,0,0\n";
  std::set<std::string> documented;
  std::string line;
  while (std::getline(doc, line)) {
    if (line.rfind("| `device.", 0) != 0) continue;
    const size_t end = line.find('`', 10);
    const std::string key = line.substr(10, end - 10);
    std::string def = line.substr(line.find('|', end) + 1);
    def = def.substr(0, def.find('|'));
    while (!def.empty() && def.front() == ' ') def.erase(0, 1);
    while (!def.empty() && def.back() == ' ') def.pop_back();
    if (key == "recording") def = rec.string();
    if (key == "trajectory") def = traj.string();
    if (def.empty()) def = "\"\"";
    documented.insert(key);
    const std::string yaml = "device:\n  " + std::string(key == "recording" ? "kind: replay\n  " : "") + key + ": " + def +
                             "\ntissues:\n  - name: a\n    patch: {width: 0.01, height: 0.01, spacing: 0.001}\n";
    auto s = palpate::parse_scene(yaml, "doc.yaml", ".");
    EXPECT_TRUE(s.ok()) << "docs/haptics.md documents device." << key << " (default " << def
                        << ") but the loader says: " << s.error().message;
  }
  EXPECT_GE(documented.size(), 14u);
  for (const auto& p : palpate::param_table(static_cast<const palpate::DeviceDef*>(nullptr)))
    EXPECT_TRUE(documented.count(p.key)) << "device." << p.key << " loads but docs/haptics.md does not list it";
}

// A patch too large to build on this machine is refused at load, naming its spacing and saying
// how much it would take (a 1 m patch at 0.1 mm died of SIGABRT after 6.7 s); 1 m at 10 µm is
// 1.2e10 particles, past any machine's memory.
TEST(SceneErrors, APatchTooLargeToBuildIsRefusedNamingItsSpacing) {
  const std::string m =
      error_of("tissues:\n  - name: a\n    patch:\n      width: 1\n      height: 1\n      spacing: 0.00001\n");
  EXPECT_EQ(m.rfind("s.yaml:6: tissues[0].patch.spacing: a 1 m x 1 m patch at 1e-05 m spacing is about 1.2e+10 "
                    "particles, about 3.5e+03 GB to build, more than this machine's ",
                    0),
            0u)
      << m;
  EXPECT_NE(m.find("expected a coarser spacing or a smaller patch"), std::string::npos) << m;
}

// A path that is not a regular file is refused at once, saying what it is, before anything opens
// it: /dev/zero used to be read until the out-of-memory killer ended the run (23.4 GB), a FIFO
// blocked forever, a directory as material.predictor reported "out of memory".
TEST(SceneLoad, PathsThatAreNotRegularFilesAreRefusedAtOnce) {
  auto zero = palpate::load_scene("/dev/zero");
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.error().message, "/dev/zero: is a character device, not a regular file; expected a YAML scene file");
  const fs::path fifo = fs::temp_directory_path() / "palpate_test_scene.fifo";
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto f = palpate::load_scene(fifo);  // returns: nothing opens the FIFO
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.error().message, fifo.string() + ": is a FIFO (named pipe), not a regular file; expected a YAML scene file");

  // Inside a scene: the key, its line, and what the path is.
  auto mesh = parse_scene("tissues:\n  - name: a\n    model: mass_spring\n    mesh: {file: " + fifo.string() + "}\n", "s.yaml");
  ASSERT_FALSE(mesh.ok());
  EXPECT_NE(mesh.error().message.find("s.yaml:4: tissues[0].mesh.file: " + fifo.string() + ": is a FIFO"), std::string::npos)
      << mesh.error().message;
  auto rec = parse_scene(std::string("device: {kind: replay, recording: /dev/urandom}\n") + kOneTissue, "s.yaml");
  ASSERT_FALSE(rec.ok());
  EXPECT_NE(rec.error().message.find("s.yaml:1: device.recording: /dev/urandom: is a character device"), std::string::npos)
      << rec.error().message;
  fs::remove(fifo);

  // The predictor file: a directory is named as one.
  EXPECT_EQ(palpate::check_regular_file(kTestData, "a palpate predictor file").error().message,
            kTestData.string() + ": is a directory, not a regular file; expected a palpate predictor file");
}

// The mass-spring material's rules that span keys are checked at load, naming the line and key
// (the scene table's range for poisson_ratio is [0, 0.499]; the volume term needs 0.25 or more).
TEST(SceneLoad, SpringMaterialRulesAcrossKeysAreCheckedAtLoad) {
  auto error_of = [](const std::string& material) {
    auto s = parse_scene("tissues:\n  - name: a\n    model: mass_spring\n    patch: {}\n    material:\n" + material, "s.yaml");
    return s ? std::string("accepted") : s.error().message;
  };
  EXPECT_EQ(error_of("      youngs_modulus: 5000\n      poisson_ratio: 0.2\n      topology: tet_edges\n"),
            "s.yaml:7: tissues[0].material.poisson_ratio: 0.2 is below 0.25: a spring network alone has Poisson's "
            "ratio 0.25 and the volume term only adds to it; expected 0 (no volume term) or 0.25 to 0.499");
  EXPECT_EQ(error_of("      poisson_ratio: 0.45\n      topology: tet_edges\n"),
            "s.yaml:6: tissues[0].material.poisson_ratio: needs youngs_modulus > 0 (the volume term's modulus is "
            "derived from both)");
  EXPECT_EQ(error_of("      youngs_modulus: 5000\n      poisson_ratio: 0.45\n      topology: all_pairs\n"),
            "s.yaml:7: tissues[0].material.poisson_ratio: needs topology tet_edges or edges on a tetrahedral mesh, "
            "not all_pairs");
  EXPECT_EQ(error_of("      topology: tet_edges\n      fill_max_edge: 0.002\n      fill_refine_size: 0.004\n"),
            "s.yaml:8: tissues[0].material.fill_refine_size: 0.004 m is larger than fill_max_edge 0.002 m; expected "
            "the refined region finer than the rest");
  EXPECT_EQ(error_of("      fill_refine_size: 0.004\n"),
            "s.yaml:6: tissues[0].material.fill_refine_size: grades the tetrahedral fill of a surface: needs "
            "topology tet_edges");
  EXPECT_EQ(error_of("      youngs_modulus: 5000\n      poisson_ratio: 0.45\n      topology: tet_edges\n"), "accepted");
  EXPECT_EQ(error_of("      youngs_modulus: 5000\n      poisson_ratio: 0\n"), "accepted");
}

// Issue 35, item 2: a scripted needle moved sideways to its own shaft drags the tissues it is in
// off its track (a 70° path with tool.axis left at 45°). It loads and runs as written, with a
// warning naming the file, line and waypoint, the angle, and what to do; a path along the shaft,
// or with waypoint directions along it, or a tool that is not a needle, has none.
TEST(SceneWarnings, AScriptedNeedleMovedSidewaysToItsShaftIsWarnedAbout) {
  const std::string head = "tool: {kind: needle, axis: [0, -0.70711, 0.70711]}\n"
                           "tissues:\n  - name: a\n    patch: {spacing: 0.002}\n";
  // 70° to the skin (y = 0 plane): 25° off the 45° shaft; 13.8 mm in along it.
  const std::string steep = head + "device:\n  waypoints:\n"
                                   "    - {t: 0, position: [0, 0.005, -0.00182]}\n"
                                   "    - {t: 2, position: [0, -0.013, 0.00473]}\n";
  auto r = parse_scene(steep, "steep.yaml");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->warnings.size(), 1u);
  const std::string& w = r->warnings[0];
  EXPECT_NE(w.find("steep.yaml:8: device.waypoints[1]: the needle moves 19.2 mm at 25° to its own shaft between "
                   "t = 0 s and 2 s"),
            std::string::npos)
      << w;
  EXPECT_NE(w.find("aim the path along tool.axis"), std::string::npos) << w;
  // Along the shaft: none. A direction on the waypoints that follows the path: none.
  auto along = parse_scene(head + "device:\n  waypoints:\n    - {t: 0, position: [0, 0.005, -0.005]}\n"
                                  "    - {t: 2, position: [0, -0.013, 0.013]}\n",
                           "along.yaml");
  ASSERT_TRUE(along.ok()) << along.error().message;
  EXPECT_TRUE(along->warnings.empty()) << along->warnings[0];
  auto turned = parse_scene(head + "device:\n  waypoints:\n"
                                   "    - {t: 0, position: [0, 0.005, -0.00182], direction: [0, -0.9397, 0.342]}\n"
                                   "    - {t: 2, position: [0, -0.013, 0.00473]}\n",
                            "turned.yaml");
  ASSERT_TRUE(turned.ok()) << turned.error().message;
  EXPECT_TRUE(turned->warnings.empty()) << turned->warnings[0];
  // Across the shaft (75° or more: a move to the next site above the skin), under 1 mm, or a
  // sphere: none.
  auto across = parse_scene(head + "device:\n  waypoints:\n    - {t: 0, position: [0, 0.01, 0]}\n"
                                   "    - {t: 1, position: [0.01, 0.01, 0]}\n",
                            "across.yaml");
  ASSERT_TRUE(across.ok());
  EXPECT_TRUE(across->warnings.empty()) << across->warnings[0];
  auto small = parse_scene(head + "device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0]}\n"
                                  "    - {t: 1, position: [0.0009, 0, 0]}\n",
                           "small.yaml");
  ASSERT_TRUE(small.ok());
  EXPECT_TRUE(small->warnings.empty());
  auto sphere = parse_scene("tool: {kind: sphere, radius: 0.003}\n"
                            "tissues:\n  - name: a\n    patch: {spacing: 0.002}\n"
                            "device:\n  waypoints:\n    - {t: 0, position: [0, 0, 0]}\n"
                            "    - {t: 1, position: [0.01, 0, 0]}\n",
                            "sphere.yaml");
  ASSERT_TRUE(sphere.ok());
  EXPECT_TRUE(sphere->warnings.empty());
  // No shipped scene is warned about.
  for (const auto& entry : std::filesystem::directory_iterator(PALPATE_SOURCE_DIR "/data/scenes")) {
    if (entry.path().extension() != ".yaml") continue;
    auto scene = load_scene(entry.path());
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    EXPECT_TRUE(scene->warnings.empty()) << entry.path() << ": " << scene->warnings[0];
  }
}
