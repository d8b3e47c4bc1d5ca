// palpate/scene_def.h — scene definitions: plain structs with defaults, and the tables of their
// keys (type, unit, range, meaning). The core layer: every layer reads a Def, none needs the parser
// (palpate/scene.h) for it.
#pragma once

#include <palpate/charged_def.h>
#include <palpate/core.h>
#include <palpate/params.h>
#include <palpate/spring_def.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace palpate {

struct ToolDef {
  std::string kind = "sphere";  // sphere | needle | blade
  double radius = 0.001;        // m, sphere radius, needle shaft radius, or half a blade's thickness
  double length = 0.08;         // m, needle shaft length or a blade's edge length (unused by a sphere)
  Vec3 axis = Vec3(0, -1, 0);   // unit direction the needle points, in the device frame
};

struct Waypoint {
  double t = 0;                     // s
  Vec3 position = Vec3::Zero();     // m
  // Unit direction the needle points at time t (scene frame); zero = not given: the previous
  // waypoint's direction holds (the scene's tool.axis, i.e. the device at identity, for the first).
  Vec3 direction = Vec3::Zero();
  // The grasp (device button 1) closed from this waypoint until the next one: a scripted grasper.
  bool grasp = false;
  int line = 0;                     // where it was read (messages); 0 = not from a file
};

struct DeviceDef {
  std::string kind = "scripted";    // scripted | replay | openhaptics | forcedimension
  std::vector<Waypoint> waypoints;  // scripted: timed waypoints, linearly interpolated (slerp)
  std::filesystem::path trajectory; // scripted: CSV of t,x,y,z[,dx,dy,dz] instead of waypoints
  std::filesystem::path recording;  // replay: a run's CSV
  double max_force = 3.3;           // N (Geomagic Touch peak force)
  double max_force_rate = 200.0;    // N/s, largest change of the force sent
  double ramp_in = 0.1;             // s, forces ramp in from zero over this time at start
  double stiffness = 1000.0;        // N/m, device's nominal maximum stiffness (virtual coupling)
  double damping = 2.0;             // N·s/m, device's nominal maximum damping
  bool passivity = true;            // the passivity observer and controller on its force path (safety.h)
  double passivity_window = 0.03;   // s, free of force this long, the observer forgets its credit
  double passivity_velocity_floor = 0.01;  // m/s, the controller's |v| floor
  double passivity_max_damping = 0.9;      // the controller's damping cap, a fraction of `damping`
  std::string coupling = "direct";  // direct | virtual: force from the HIP, or a proxy coupling
  double proxy_mass = 0.001;        // kg, virtual coupling: mass of the tool proxy
  double overrun_margin = 0.0005;   // s, a tick's work this far past its deadline gives zero force
  double stall_timeout = 0.05;      // s, a physics thread silent this long (or ten of its periods, when longer) gives zero force
  std::string hd_library = "libHD.so";  // openhaptics: the HD library dlopen'ed at run time
  std::string hd_device;            // openhaptics: device configuration name ("" = default)
  std::string dhd_library;          // forcedimension: the DHD library ("" = libdhd.so.3, then libdhd.so)
  int dhd_index = 0;                // forcedimension: which connected device (0 = the first)
  int dhd_serial = 0;               // forcedimension: the device's serial number (0 = by dhd_index)
};

struct CameraDef {
  Vec3 position = Vec3(0.06, 0.05, 0.08);  // m
  Vec3 target = Vec3::Zero();              // m
  double fov = 40.0;                       // degrees, vertical
  int width = 800, height = 600;           // pixels
};

// A generated rectangular patch of particles or vertices.
struct PatchDef {
  std::string shape = "flat";         // flat | cylinder | sphere
  double width = 0.04;                // m, along the patch's u direction
  double height = 0.04;               // m, along its v direction
  double spacing = 0.001;             // m, distance between neighbouring particles
  double radius = 0.02;               // m, for cylinder and sphere shapes
  Vec3 center = Vec3::Zero();         // m, centre of the patch
  Vec3 normal = Vec3(0, 1, 0);        // outward normal at the centre
};

// A mesh file and how to place it.
struct MeshRef {
  std::filesystem::path file;         // resolved against the scene file's directory
  double scale = 1.0;                 // multiplies coordinates (mesh units to metres)
  Vec3 translate = Vec3::Zero();      // m, added after scaling
};

struct TissueDef {
  std::string name;
  std::string model = "charged_particles";  // charged_particles | mass_spring
  std::string role = "tissue";             // tissue | skin | fat | muscle | vein | artery | organ
  std::optional<PatchDef> patch;           // exactly one of patch and mesh
  std::optional<MeshRef> mesh;
  ChargedMaterialDef charged;              // used when model == charged_particles
  SpringMaterialDef spring;                // used when model == mass_spring
  std::vector<int> anchors;                // fixed vertex or particle indices
  int line = 0;                            // line in the scene file, for messages
};

// A generated neck region for central venous catheter insertion (src/anatomy/neck.cpp, docs/cvc.md):
// skin and subcutaneous fat on a curved neck surface, the internal jugular vein (IJV) and the common
// carotid artery (CCA) as tubes. Coordinates: y up (anterior, patient supine), z along the neck,
// x lateral (+) / medial (−); the skin's top is at the origin. Defaults are published figures.
// A generated layer's material changed from its calibrated default (anatomy.layers.<name>): only
// the keys the scene names are applied, each range-checked at load as a tissue's material is.
struct AnatomyLayerDef {
  std::string name;               // one of kNeckLayers
  ChargedMaterialDef material;    // the keys named below, read from the scene
  std::vector<std::string> keys;  // which keys the scene set
  int line = 0;                   // in the scene file
};
// The neck's generated layers, outside in (their scene names).
inline constexpr const char* kNeckLayers[] = {"skin", "fat", "ijv", "cca"};

struct NeckDef {
  std::string kind = "neck";
  double neck_radius = 0.06;      // m, curvature of the skin across the neck (axis along z)
  double width = 0.06;            // m, extent across the neck (x)
  double length = 0.09;           // m, extent along the neck (z)
  double skin_thickness = 0.0015; // m, epidermis + dermis, anterior neck (Lee & Hwang 2002)
  double ijv_depth = 0.0114;      // m, skin to the IJV's anterior wall (Wenzel et al. 2022, median)
  double ijv_diameter = 0.013;    // m (Thai CT 2013: right 14.9 ± 4.0 mm; Lee & Lee 2004: 14.2 mm)
  double ijv_x = 0.0;             // m, lateral position of the IJV's axis
  double cca_diameter = 0.0063;   // m (Krejza et al. 2006: 6.1 women, 6.5 men)
  double cca_gap = 0.0013;        // m, between the two walls (Thai CT 2013: right 1.3 ± 0.6 mm)
  double cca_angle = 20.0;        // degrees below medial: where the CCA lies seen from the IJV
                                  //   (0 = beside it, medial; 90 = right under it)
  double spacing = 0.001;         // m, particle spacing of skin and fat
  double vessel_spacing = 0.0008; // m, particle spacing of the vessel walls
  // The layers the ultrasound image shows between skin and vessels, and the neck's mechanics under
  // the probe (docs/ultrasound.md): an elastic half-space with the vessels as collapsible tubes.
  double fat_thickness = 0.004;     // m, subcutaneous fat under the skin (image)
  double muscle_thickness = 0.005;  // m, sternocleidomastoid under the fat (image)
  double tissue_modulus = 10e3;     // Pa, Young's modulus of the neck's soft tissue (fat ≈ 3, muscle ≈ 10–20 kPa)
  double poisson = 0.45;            // Poisson's ratio of the neck's soft tissue
  double venous_pressure = 667;     // Pa, pressure in the IJV (5 mmHg; normal CVP 3–6 mmHg)
  double vein_wall_stiffness = 40;  // Pa, the IJV's tube-law stiffness K_p (Shapiro 1977): E h³/(12(1−ν²)R³)
  double arterial_pressure = 12400; // Pa, mean pressure in the CCA (93 mmHg)
  double pulse_pressure = 5330;     // Pa, systolic minus diastolic (40 mmHg)
  double heart_rate = 1.2;          // Hz (72 beats per minute)
  double artery_stiffness = 8;      // the CCA's stiffness parameter β (Hayashi), ln(P/Ps) = β(D/Ds − 1)
  std::vector<AnatomyLayerDef> layers;  // materials changed from the calibrated defaults
  std::string file = "scene";       // where the section was read (messages): the scene's name
  int line = 0;                     // and its line
};

// The ultrasound probe, a second tool held in the other hand (docs/ultrasound.md): a linear
// transducer whose footprint rests on the neck's skin, driven by its own device and safety filter,
// and the B-mode image of the plane under it. Needs an `anatomy` (the image is of the neck).
// At identity orientation the probe faces `axis` (into the skin) with its array along `lateral`;
// the image plane is spanned by the two.
struct ProbeDef {
  double width = 0.038;           // m, footprint along the array (the image's width)
  double thickness = 0.010;       // m, footprint across the array (elevation)
  Vec3 axis = Vec3(0, -1, 0);     // unit, direction the probe faces at identity (beam direction)
  Vec3 lateral = Vec3(1, 0, 0);   // unit, along the array at identity; perpendicular to `axis`
  double frequency = 10e6;        // Hz, centre frequency (7–13 MHz linear probe)
  double depth = 0.04;            // m, imaging depth
  double gain = 0.0;              // dB, overall gain added after time-gain compensation
  double dynamic_range = 60.0;    // dB, shown between black and white after log compression
  double slice_thickness = 0.0015;// m, elevation beam width at focus
  int image_width = 256;          // pixels across the array
  int image_height = 256;         // pixels in depth
  int seed = 1;                   // speckle's scatterer field (same seed, same images)
  DeviceDef device;               // the second hand's device
};

// A grasper in the other hand (a second tool on the tissues, with its own device and safety
// filter): a sphere of `radius` that presses on mass-spring tissues as a probe and grasps while its
// device's button 1 is down (a scripted waypoint's `grasp`), as the scene's tool does. It retracts
// what the scene's tool then works on: the gallbladder held up while the blade divides its
// attachment (data/scenes/gallbladder.yaml).
struct GrasperDef {
  double radius = 0.003;          // m, the closed jaws' reach (a 5 mm laparoscopic grasper)
  DeviceDef device;               // the other hand's device
};

struct SceneDef {
  std::filesystem::path file;              // where it was read from ("" if from memory)
  std::string name = "scene";
  double duration = 1.0;                   // s
  double dt = 0.001;                       // s, the haptic tick
  std::filesystem::path output = "out";    // resolved against the scene file's directory
  ToolDef tool;
  DeviceDef device;
  std::optional<CameraDef> camera;
  std::optional<NeckDef> anatomy;          // its tissues are generated by expand_anatomy (the
                                           // Simulation's build), before `tissues`
  bool anatomy_expanded = false;           // whether `tissues` already begins with them
  std::optional<ProbeDef> probe;           // the ultrasound probe (needs `anatomy`)
  std::optional<GrasperDef> grasper;       // a grasper in the other hand (not with a probe)
  std::vector<TissueDef> tissues;
  // What loads but looks wrong, each naming the file, line and key and what to do (a scripted
  // needle moved sideways to its own shaft): printed by `palpate run` and `view`, scene.warnings
  // in Python. Never an error: the scene runs as written.
  std::vector<std::string> warnings;
};


std::span<const Param<ToolDef>> param_table(const ToolDef*);
std::span<const Param<DeviceDef>> param_table(const DeviceDef*);
std::span<const Param<CameraDef>> param_table(const CameraDef*);
std::span<const Param<PatchDef>> param_table(const PatchDef*);
std::span<const Param<MeshRef>> param_table(const MeshRef*);
std::span<const Param<SceneDef>> param_table(const SceneDef*);
std::span<const Param<NeckDef>> param_table(const NeckDef*);
std::span<const Param<ProbeDef>> param_table(const ProbeDef*);
std::span<const Param<GrasperDef>> param_table(const GrasperDef*);
std::span<const Param<TissueDef>> param_table(const TissueDef*);
std::span<const Param<Waypoint>> param_table(const Waypoint*);

}  // namespace palpate
