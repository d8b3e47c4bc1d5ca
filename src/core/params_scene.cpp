// params_scene.cpp — the scene file's key tables (scene, tool, device, waypoint, camera, probe,
// neck, tissue, patch, mesh): type, unit, range, meaning. With the Defs in the core layer, so the
// parser (io), the anatomy and the models all read one range per key.
#include <palpate/scene_def.h>

namespace palpate {

std::span<const Param<SceneDef>> param_table(const SceneDef*) {
  using D = SceneDef;
  static const Param<D> table[] = {
      {"name", &D::name, 0, 0, "", "the scene's name, used in outputs"},
      {"duration", &D::duration, 1e-5, 3600.0, "s", "how long a run lasts"},
      {"dt", &D::dt, 1e-5, 0.1, "s", "the haptic tick, at most `duration` (0.001 = 1 kHz)"},
      {"output", &D::output, 0, 0, "", "directory a run writes to, relative to the scene file"},
  };
  return table;
}

std::span<const Param<ToolDef>> param_table(const ToolDef*) {
  using D = ToolDef;
  static const Param<D> table[] = {
      {"kind", &D::kind, 0, 0, "", "a sphere probe, a needle, or a blade (a scalpel's edge)", "sphere|needle|blade"},
      {"radius", &D::radius, 1e-5, 0.05, "m", "sphere radius, or the needle shaft's radius"},
      {"length", &D::length, 0.0, 0.5, "m", "needle shaft length, or a blade's edge length; > 0 for both (a sphere ignores it)"},
      {"axis", &D::axis, -1.0, 1.0, "",
       "direction the needle points, handle to tip, device frame; non-zero, normalised on load"},
  };
  return table;
}

std::span<const Param<DeviceDef>> param_table(const DeviceDef*) {
  using D = DeviceDef;
  static const Param<D> table[] = {
      {"kind", &D::kind, 0, 0, "", "where the tool's pose comes from", "scripted|replay|openhaptics|forcedimension"},
      {"trajectory", &D::trajectory, 0, 0, "",
       "scripted: CSV of t,x,y,z (s, m) instead of `waypoints`; must exist"},
      {"recording", &D::recording, 0, 0, "", "replay: a run's CSV to play back; required, must exist"},
      {"max_force", &D::max_force, 0.0, 50.0, "N", "largest force sent to the device"},
      {"max_force_rate", &D::max_force_rate, 0.0, 1e5, "N/s", "largest change of the force sent"},
      {"ramp_in", &D::ramp_in, 0.0, 10.0, "s", "forces ramp in from zero over this time at the start"},
      {"stiffness", &D::stiffness, 0.0, 1e5, "N/m", "device's nominal maximum stiffness (virtual coupling)"},
      {"damping", &D::damping, 0.0, 1e3, "N·s/m", "device's nominal maximum damping"},
      {"passivity", &D::passivity, 0, 1, "",
       "time-domain passivity (Hannaford & Ryu 2002): damping added when the tool would give the hand energy "
       "it never put in; false leaves the observer only (its E still in run.csv)"},
      {"passivity_window", &D::passivity_window, 0.0, 10.0, "s",
       "passivity: the force this long below 1 mN, the observer forgets the energy the tissue dissipated"},
      {"passivity_velocity_floor", &D::passivity_velocity_floor, 1e-4, 1.0, "m/s",
       "passivity: the speed below which the damping is computed as at this speed (|v|² floored)"},
      {"passivity_max_damping", &D::passivity_max_damping, 0.0, 1.0, "",
       "passivity: the largest damping added, as a fraction of the device's `damping`"},
      {"coupling", &D::coupling, 0, 0, "",
       "force rendering: the force on the HIP (direct), or a spring-damper to a tool proxy the tissues push "
       "(virtual)", "direct|virtual"},
      {"proxy_mass", &D::proxy_mass, 1e-6, 1.0, "kg", "virtual coupling: mass of the tool proxy"},
      {"overrun_margin", &D::overrun_margin, 0.0, 0.1, "s",
       "watchdog: a realtime tick's work this far past its deadline sends zero force"},
      {"stall_timeout", &D::stall_timeout, 0.001, 10.0, "s",
       "watchdog: a physics thread silent this long sends zero force"},
      {"hd_library", &D::hd_library, 0, 0, "", "openhaptics: the HD library (file name or path) loaded at run time"},
      {"hd_device", &D::hd_device, 0, 0, "", "openhaptics: HD device configuration name (\"\" = the default device)"},
      {"dhd_library", &D::dhd_library, 0, 0, "",
       "forcedimension: the DHD library (file name or path) loaded at run time; \"\" = libdhd.so.3, then libdhd.so"},
      {"dhd_index", &D::dhd_index, 0, 15, "", "forcedimension: which connected device to open (0 = the first)"},
      {"dhd_serial", &D::dhd_serial, 0, 65535, "",
       "forcedimension: the serial number of the device to open (0 = by dhd_index); not with dhd_index"},
  };
  return table;
}

std::span<const Param<Waypoint>> param_table(const Waypoint*) {
  using D = Waypoint;
  static const Param<D> table[] = {
      {"t", &D::t, 0.0, 3600.0, "s", "time of the waypoint; not before the previous one"},
      {"position", &D::position, -10.0, 10.0, "m", "tool position (the HIP) at time t"},
      {"direction", &D::direction, -1.0, 1.0, "",
       "direction the needle points at time t, handle to tip; non-zero, normalised on load; "
       "the device reports the shortest-arc rotation from `tool.axis` to it, slerped between waypoints",
       "", "the previous waypoint's (`tool.axis` for the first)"},
      {"grasp", &D::grasp, 0, 1, "",
       "the grasp (device button 1) is closed from this waypoint until the next one: a scripted grasper "
       "holds what it closed on and lets go at the first waypoint without it"},
  };
  return table;
}

std::span<const Param<CameraDef>> param_table(const CameraDef*) {
  using D = CameraDef;
  static const Param<D> table[] = {
      {"position", &D::position, -100.0, 100.0, "m", "eye position"},
      {"target", &D::target, -100.0, 100.0, "m", "point looked at; differs from `position`"},
      {"fov", &D::fov, 1.0, 170.0, "degrees", "vertical field of view"},
      {"width", &D::width, 16, 16384, "pixels", "image width"},
      {"height", &D::height, 16, 16384, "pixels", "image height"},
  };
  return table;
}

std::span<const Param<GrasperDef>> param_table(const GrasperDef*) {
  using D = GrasperDef;
  static const Param<D> table[] = {
      {"radius", &D::radius, 1e-4, 0.05, "m",
       "the closed jaws' reach: presses as a sphere of this radius and grasps the vertices within it "
       "(and the material's grasp_radius)"},
  };
  return table;
}

std::span<const Param<ProbeDef>> param_table(const ProbeDef*) {
  using D = ProbeDef;
  static const Param<D> table[] = {
      {"width", &D::width, 0.005, 0.1, "m", "footprint along the array: the image's width"},
      {"thickness", &D::thickness, 0.002, 0.05, "m", "footprint across the array (elevation)"},
      {"axis", &D::axis, -1.0, 1.0, "", "direction the probe faces at identity orientation (the beam); normalised on load"},
      {"lateral", &D::lateral, -1.0, 1.0, "",
       "direction of the array at identity orientation; perpendicular to `axis`; normalised on load"},
      {"frequency", &D::frequency, 1e6, 20e6, "Hz", "centre frequency (linear vascular probe: 7–13 MHz)"},
      {"depth", &D::depth, 0.01, 0.1, "m", "imaging depth"},
      {"gain", &D::gain, -40.0, 40.0, "dB", "overall gain after time-gain compensation"},
      {"dynamic_range", &D::dynamic_range, 20.0, 100.0, "dB", "range shown from black to white after log compression"},
      {"slice_thickness", &D::slice_thickness, 2e-4, 0.01, "m", "elevation beam width at focus"},
      {"image_width", &D::image_width, 16, 2048, "pixels", "image columns (across the array)"},
      {"image_height", &D::image_height, 16, 2048, "pixels", "image rows (in depth)"},
      {"seed", &D::seed, 0, 2147483647, "", "the speckle's scatterer field: the same seed gives the same images"},
  };
  return table;
}

std::span<const Param<NeckDef>> param_table(const NeckDef*) {
  using D = NeckDef;
  static const Param<D> table[] = {
      {"kind", &D::kind, 0, 0, "", "the generated anatomy", "neck"},
      {"neck_radius", &D::neck_radius, 0.02, 0.2, "m", "curvature radius of the skin across the neck (axis along z)"},
      {"width", &D::width, 0.02, 0.2, "m", "extent of the region across the neck (x)"},
      {"length", &D::length, 0.02, 0.2, "m", "extent of the region along the neck (z)"},
      {"skin_thickness", &D::skin_thickness, 2e-4, 0.01, "m", "epidermis + dermis (Lee & Hwang 2002)"},
      {"ijv_depth", &D::ijv_depth, 0.002, 0.05, "m",
       "skin to the internal jugular vein's anterior wall (Wenzel et al. 2022: median 11.4 mm)"},
      {"ijv_diameter", &D::ijv_diameter, 0.002, 0.03, "m", "the vein's diameter (CT: 14.9 ± 4.0 mm right)"},
      {"ijv_x", &D::ijv_x, -0.05, 0.05, "m", "lateral position of the vein's axis (+ lateral)"},
      {"cca_diameter", &D::cca_diameter, 0.002, 0.015, "m", "the common carotid's diameter (Krejza 2006: 6.1–6.5 mm)"},
      {"cca_gap", &D::cca_gap, 0.0, 0.02, "m", "between the vein's and the artery's walls (CT: 1.3 ± 0.6 mm)"},
      {"cca_angle", &D::cca_angle, -30.0, 90.0, "degrees",
       "where the artery lies seen from the vein: 0 beside it (medial), 90 right under it (overlap)"},
      {"spacing", &D::spacing, 2e-4, 0.005, "m", "particle spacing of skin and fat"},
      {"vessel_spacing", &D::vessel_spacing, 1e-4, 0.005, "m", "particle spacing of the vessel walls"},
      {"fat_thickness", &D::fat_thickness, 0.0, 0.05, "m", "subcutaneous fat under the skin, as the ultrasound shows it"},
      {"muscle_thickness", &D::muscle_thickness, 0.0, 0.05, "m",
       "sternocleidomastoid under the fat, as the ultrasound shows it"},
      {"tissue_modulus", &D::tissue_modulus, 500.0, 1e6, "Pa",
       "Young's modulus of the neck's soft tissue under the probe (elastic half-space)"},
      {"poisson", &D::poisson, 0.0, 0.499, "", "Poisson's ratio of the neck's soft tissue"},
      {"venous_pressure", &D::venous_pressure, 0.0, 5000.0, "Pa", "pressure in the vein (667 Pa = 5 mmHg; CVP 3–6 mmHg)"},
      {"vein_wall_stiffness", &D::vein_wall_stiffness, 1.0, 1e5, "Pa",
       "the vein's tube-law stiffness K_p: how hard it resists collapse (Shapiro 1977; thin wall: E h^3/(12(1-nu^2) R^3))"},
      {"arterial_pressure", &D::arterial_pressure, 1000.0, 30000.0, "Pa", "mean pressure in the artery (12400 Pa = 93 mmHg)"},
      {"pulse_pressure", &D::pulse_pressure, 0.0, 15000.0, "Pa", "systolic minus diastolic pressure (5330 Pa = 40 mmHg)"},
      {"heart_rate", &D::heart_rate, 0.0, 4.0, "Hz", "pulse frequency (0 = no pulse)"},
      {"artery_stiffness", &D::artery_stiffness, 1.0, 50.0, "",
       "the artery's stiffness parameter β: ln(P/Ps) = β(D/Ds − 1) (Hayashi 1980; carotid ≈ 5–10)"},
  };
  return table;
}

std::span<const Param<TissueDef>> param_table(const TissueDef*) {
  using D = TissueDef;
  static const Param<D> table[] = {
      {"name", &D::name, 0, 0, "", "unique name of the tissue"},
      {"model", &D::model, 0, 0, "", "the tissue model; picks the `material` table",
       "charged_particles|mass_spring"},
      {"role", &D::role, 0, 0, "",
       "what the tissue is in the anatomy: the CVC outcome reads vein and artery walls (docs/cvc.md)",
       "tissue|skin|fat|muscle|vein|artery|organ"},
  };
  return table;
}

std::span<const Param<PatchDef>> param_table(const PatchDef*) {
  using D = PatchDef;
  static const Param<D> table[] = {
      {"shape", &D::shape, 0, 0, "",
       "surface the patch is laid on; mass_spring: flat, a solid sphere, or a gallbladder on the liver's "
       "underside (at its published size, `center` where the two meet; docs/models/cutting.md)",
       "flat|cylinder|sphere|gallbladder"},
      {"width", &D::width, 1e-4, 1.0, "m", "extent along the patch's u direction, >= spacing"},
      {"height", &D::height, 1e-4, 1.0, "m", "extent along its v direction, >= spacing"},
      {"spacing", &D::spacing, 1e-5, 0.1, "m",
       "distance between neighbouring particles (a charged patch's material means the same at any spacing)"},
      {"radius", &D::radius, 1e-4, 1.0, "m", "radius of a cylinder or sphere shape"},
      {"center", &D::center, -10.0, 10.0, "m", "centre of the patch"},
      {"normal", &D::normal, -1.0, 1.0, "", "outward normal at the centre; non-zero, normalised on load"},
  };
  return table;
}

std::span<const Param<MeshRef>> param_table(const MeshRef*) {
  using D = MeshRef;
  static const Param<D> table[] = {
      {"file", &D::file, 0, 0, "",
       "tetrahedral (.msh, .node/.ele, .vtk) or surface (.obj, .stl, .ply, .off) mesh; must exist"},
      {"scale", &D::scale, 1e-6, 1e6, "", "multiplies the file's coordinates (mesh units to metres)"},
      {"translate", &D::translate, -100.0, 100.0, "m", "added after scaling"},
  };
  return table;
}

}  // namespace palpate
