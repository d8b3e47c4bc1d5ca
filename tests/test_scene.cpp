// test_scene.cpp — the YAML scene loader: every value read and the defaults (the errors for bad
// input, the example scenes and the generated reference: test_scene_errors.cpp).
#include "scene_fixtures.h"

using namespace palpate;
using namespace scene_test;

TEST(Scene, GoodSceneRoundTripsEveryValue) {
  const std::string yaml = R"(name: full
duration: 2.5
dt: 0.0005
output: results/run1
tool:
  kind: needle
  radius: 0.0005
  length: 0.07
  axis: [0, 0, -0.5]
device:
  kind: scripted
  max_force: 2.5
  max_force_rate: 150
  ramp_in: 0.2
  stiffness: 800
  damping: 1.5
  waypoints:
    - {t: 0, position: [0.001, 0.02, -0.003]}
    - {t: 1.5, position: [0, -0.01, 0]}
    - {t: 1.5, position: [0, -0.01, 0.002]}
camera:
  position: [0.1, 0.2, 0.3]
  target: [0, -0.01, 0]
  fov: 55
  width: 640
  height: 480
tissues:
  - name: skin
    model: charged_particles
    patch:
      shape: cylinder
      width: 0.03
      height: 0.02
      spacing: 0.0008
      radius: 0.015
      center: [0.001, -0.002, 0.003]
      normal: [0, 0, 0.5]
    material:
      max_displacement: 0.005
      elasticity: 12.5
      particle_radius: 0.002
      max_separation: 0.0012
      linear_share: 0.4
      friction_per_length: 70
      puncture_force: 1.8
      hole_closes: true
    anchors: [0, 5, 17]
  - name: liver
    model: mass_spring
    mesh:
      file: liver.msh
      scale: 0.01
      translate: [0.01, -0.02, 0.03]
    material:
      topology: tet_edges
      solver: sparse
      stiffness: 4500
      youngs_modulus: 3000
      spring_damping: 0.2
      point_damping: 0.7
      mass: 1.5
      density: 1060
      gravity: false
      predictor: cache/liver.pred
)";
  const fs::path base = fs::path(PALPATE_DATA_DIR "/meshes").lexically_normal();
  auto r = parse_scene(yaml, "full.yaml", PALPATE_DATA_DIR "/meshes");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const SceneDef& s = *r;
  EXPECT_EQ(s.name, "full");
  EXPECT_EQ(s.duration, 2.5);
  EXPECT_EQ(s.dt, 0.0005);
  EXPECT_EQ(s.output, base / "results/run1");
  EXPECT_EQ(s.tool.kind, "needle");
  EXPECT_EQ(s.tool.radius, 0.0005);
  EXPECT_EQ(s.tool.length, 0.07);
  EXPECT_EQ(s.tool.axis, Vec3(0, 0, -1));  // normalised
  EXPECT_EQ(s.device.kind, "scripted");
  EXPECT_EQ(s.device.max_force, 2.5);
  EXPECT_EQ(s.device.max_force_rate, 150);
  EXPECT_EQ(s.device.ramp_in, 0.2);
  EXPECT_EQ(s.device.stiffness, 800);
  EXPECT_EQ(s.device.damping, 1.5);
  ASSERT_EQ(s.device.waypoints.size(), 3u);
  EXPECT_EQ(s.device.waypoints[0].t, 0);
  EXPECT_EQ(s.device.waypoints[0].position, Vec3(0.001, 0.02, -0.003));
  EXPECT_EQ(s.device.waypoints[1].t, 1.5);
  EXPECT_EQ(s.device.waypoints[2].position, Vec3(0, -0.01, 0.002));
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->position, Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(s.camera->target, Vec3(0, -0.01, 0));
  EXPECT_EQ(s.camera->fov, 55);
  EXPECT_EQ(s.camera->width, 640);
  EXPECT_EQ(s.camera->height, 480);
  ASSERT_EQ(s.tissues.size(), 2u);

  const auto& skin = s.tissues[0];
  EXPECT_EQ(skin.name, "skin");
  EXPECT_EQ(skin.model, "charged_particles");
  EXPECT_EQ(skin.line, 28);
  ASSERT_TRUE(skin.patch.has_value());
  EXPECT_FALSE(skin.mesh.has_value());
  EXPECT_EQ(skin.patch->shape, "cylinder");
  EXPECT_EQ(skin.patch->width, 0.03);
  EXPECT_EQ(skin.patch->height, 0.02);
  EXPECT_EQ(skin.patch->spacing, 0.0008);
  EXPECT_EQ(skin.patch->radius, 0.015);
  EXPECT_EQ(skin.patch->center, Vec3(0.001, -0.002, 0.003));
  EXPECT_EQ(skin.patch->normal, Vec3(0, 0, 1));
  EXPECT_EQ(skin.charged.max_displacement, 0.005);
  EXPECT_EQ(skin.charged.elasticity, 12.5);
  EXPECT_EQ(skin.charged.particle_radius, 0.002);
  EXPECT_EQ(skin.charged.max_separation, 0.0012);
  EXPECT_EQ(skin.charged.linear_share, 0.4);
  EXPECT_EQ(skin.charged.friction_per_length, 70.0);
  EXPECT_EQ(skin.charged.puncture_force, 1.8);
  EXPECT_TRUE(skin.charged.hole_closes);
  EXPECT_EQ(skin.anchors, (std::vector<int>{0, 5, 17}));

  const auto& liver = s.tissues[1];
  EXPECT_EQ(liver.name, "liver");
  EXPECT_EQ(liver.model, "mass_spring");
  EXPECT_EQ(liver.line, 48);
  ASSERT_TRUE(liver.mesh.has_value());
  EXPECT_FALSE(liver.patch.has_value());
  EXPECT_EQ(liver.mesh->file, base / "liver.msh");
  EXPECT_EQ(liver.mesh->scale, 0.01);
  EXPECT_EQ(liver.mesh->translate, Vec3(0.01, -0.02, 0.03));
  EXPECT_EQ(liver.spring.topology, "tet_edges");
  EXPECT_EQ(liver.spring.solver, "sparse");
  EXPECT_EQ(liver.spring.stiffness, 4500);
  EXPECT_EQ(liver.spring.youngs_modulus, 3000);
  EXPECT_EQ(liver.spring.spring_damping, 0.2);
  EXPECT_EQ(liver.spring.point_damping, 0.7);
  EXPECT_EQ(liver.spring.mass, 1.5);
  EXPECT_EQ(liver.spring.density, 1060);
  EXPECT_FALSE(liver.spring.gravity);
  EXPECT_EQ(liver.spring.predictor, (base / "cache/liver.pred").string());
  EXPECT_TRUE(liver.anchors.empty());
}

TEST(Scene, DefaultsApplyToEveryOmittedKey) {
  auto r = parse_scene(kOneTissue, "min.yaml", "/scenes");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const SceneDef& s = *r;
  const SceneDef d;
  EXPECT_EQ(s.name, d.name);
  EXPECT_EQ(s.duration, d.duration);
  EXPECT_EQ(s.dt, d.dt);
  EXPECT_EQ(s.output, fs::path("/scenes/out"));
  EXPECT_EQ(s.tool.kind, d.tool.kind);
  EXPECT_EQ(s.tool.radius, d.tool.radius);
  EXPECT_EQ(s.tool.axis, d.tool.axis);
  EXPECT_EQ(s.device.kind, "scripted");
  EXPECT_TRUE(s.device.waypoints.empty());
  EXPECT_EQ(s.device.max_force, d.device.max_force);
  EXPECT_FALSE(s.camera.has_value());
  ASSERT_EQ(s.tissues.size(), 1u);
  const palpate::TissueDef& t = s.tissues[0];
  EXPECT_EQ(t.model, "charged_particles");
  EXPECT_EQ(t.line, 2);
  const palpate::PatchDef p;
  EXPECT_EQ(t.patch->shape, p.shape);
  EXPECT_EQ(t.patch->width, p.width);
  EXPECT_EQ(t.patch->spacing, p.spacing);
  EXPECT_EQ(t.patch->normal, p.normal);
  const palpate::ChargedMaterialDef c;
  EXPECT_EQ(t.charged.max_displacement, c.max_displacement);
  EXPECT_EQ(t.charged.max_separation, c.max_separation);
  EXPECT_EQ(t.charged.puncture_force, c.puncture_force);
  EXPECT_EQ(t.spring.solver, palpate::SpringMaterialDef{}.solver);
  // A camera section with no keys is the default camera.
  auto cam = parse_scene(std::string("camera: {}\n") + kOneTissue, "min.yaml");
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  ASSERT_TRUE(cam->camera.has_value());
  EXPECT_EQ(cam->camera->width, palpate::CameraDef{}.width);
  EXPECT_EQ(cam->camera->position, palpate::CameraDef{}.position);
}

// Every table: keys unique, ranges ordered, and the member's default inside its own range/choices.
template <class Def>
void check_table_defaults() {
  const Def def{};
  std::set<std::string> keys;
  for (const auto& p : palpate::param_table(static_cast<const Def*>(nullptr))) {
    EXPECT_TRUE(keys.insert(p.key).second) << "duplicate key " << p.key;
    EXPECT_LE(p.min, p.max) << p.key;
    EXPECT_TRUE(*p.doc) << p.key << " has no doc";
    std::visit(
        [&](auto member) {
          const auto& v = def.*member;
          using T = std::remove_cvref_t<decltype(v)>;
          if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int>) {
            EXPECT_GE(static_cast<double>(v), p.min) << p.key;
            EXPECT_LE(static_cast<double>(v), p.max) << p.key;
          } else if constexpr (std::is_same_v<T, Vec3>) {
            EXPECT_GE(v.minCoeff(), p.min) << p.key;
            EXPECT_LE(v.maxCoeff(), p.max) << p.key;
          } else if constexpr (std::is_same_v<T, std::string>) {
            if (*p.choices) {
              const std::string all = std::string("|") + p.choices + "|";
              EXPECT_NE(all.find("|" + v + "|"), std::string::npos) << p.key << " default '" << v << "'";
            }
          }
        },
        p.field);
  }
}

TEST(Scene, EveryTableDefaultLiesInItsRange) {
  check_table_defaults<palpate::SceneDef>();
  check_table_defaults<palpate::ToolDef>();
  check_table_defaults<palpate::DeviceDef>();
  check_table_defaults<palpate::Waypoint>();
  check_table_defaults<palpate::CameraDef>();
  check_table_defaults<palpate::TissueDef>();
  check_table_defaults<palpate::PatchDef>();
  check_table_defaults<palpate::MeshRef>();
  check_table_defaults<palpate::ChargedMaterialDef>();
  check_table_defaults<palpate::SpringMaterialDef>();
}
