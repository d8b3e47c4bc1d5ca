// scene_yaml.cpp — the YAML scene parser (the only file that includes yaml-cpp): each section read
// through its Def's parameter table (io/yaml_read.h), plus the checks that span keys (dt <= duration,
// patch vs mesh, a spring material's Poisson ratio, ...).
#include "core/memory.h"
#include "io/scene_params.h"
#include "io/yaml_read.h"

#include <palpate/scene.h>

#include <fmt/format.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <locale.h>
#include <map>
#include <sstream>
#include <type_traits>
#include <unordered_set>
#include <unistd.h>
#include <vector>

namespace palpate {
namespace {

namespace fs = std::filesystem;
using namespace scene_yaml;

// The mass-spring material's rules that span several keys, checked here once with the scene's line
// and key (the network builder keeps its own guard for programs that build networks directly).
void check_spring_rules(const Ctx& c, const SpringMaterialDef& m, const Keys& mk, int mline, const std::string& mpath) {
  const int pline = mk.line_or("poisson_ratio", mline);
  if (m.poisson_ratio > 0 && m.poisson_ratio < 0.25)
    c.fail(pline, mpath + ".poisson_ratio",
           format_number(m.poisson_ratio) + " is below 0.25: a spring network alone has Poisson's ratio 0.25 and the "
           "volume term only adds to it; expected 0 (no volume term) or 0.25 to 0.499");
  if (m.poisson_ratio > 0 && !(m.youngs_modulus > 0))
    c.fail(pline, mpath + ".poisson_ratio",
           "needs youngs_modulus > 0 (the volume term's modulus is derived from both)");
  if (m.poisson_ratio > 0 && m.topology == "all_pairs")
    c.fail(pline, mpath + ".poisson_ratio", "needs topology tet_edges or edges on a tetrahedral mesh, not all_pairs");
  if (m.fill_refine_size > 0) {
    const int fline = mk.line_or("fill_refine_size", mline);
    if (m.fill_max_edge > 0 && m.fill_refine_size > m.fill_max_edge)
      c.fail(fline, mpath + ".fill_refine_size",
             format_number(m.fill_refine_size) + " m is larger than fill_max_edge " + format_number(m.fill_max_edge) +
                 " m; expected the refined region finer than the rest");
    if (m.topology != "tet_edges")
      c.fail(fline, mpath + ".fill_refine_size", "grades the tetrahedral fill of a surface: needs topology tet_edges");
  }
}

// A direction given in the file: any non-zero length, stored as a unit vector.
Vec3 unit_direction(const Ctx& c, const Vec3& v, int line, const std::string& path) {
  const double n = v.norm();
  if (!(n > 1e-9)) c.fail(line, path, "expected a non-zero direction [x, y, z], got [0, 0, 0]");
  return v / n;
}

ToolDef parse_tool(const Ctx& c, const YAML::Node& node, int line) {
  ToolDef tool;
  const Keys k = read_table(c, node, "tool", line, "tool", tool);
  tool.axis = unit_direction(c, tool.axis, k.line_or("axis", line), "tool.axis");
  if ((tool.kind == "needle" || tool.kind == "blade") && !(tool.length > 0))
    c.fail(k.line_or("length", line), "tool.length",
           "a " + tool.kind + " needs a length > 0 m (" + (tool.kind == "blade" ? "its cutting edge" : "its shaft") +
               "), got " + format_number(tool.length) + " m");
  return tool;
}

DeviceDef parse_device(const Ctx& c, const YAML::Node& node, int line, const std::string& at = "device") {
  DeviceDef dev;
  const Keys k = read_table(c, node, at, line, "device", dev, kDeviceSections);
  const bool scripted = dev.kind == "scripted";
  if (const auto w = k.sections.find("waypoints"); w != k.sections.end()) {
    const int wline = k.value_line("waypoints", line);
    if (!scripted)
      c.fail(k.line_or("waypoints", line), at + ".waypoints",
             "only a scripted device follows waypoints (kind is '" + dev.kind + "')");
    if (!w->second.IsSequence() || w->second.size() == 0)
      c.fail(wline, at + ".waypoints",
             "expected a non-empty list of {t, position[, direction]}, got " + describe(w->second));
    for (size_t i = 0; i < w->second.size(); ++i) {
      const YAML::Node e = w->second[i];
      const std::string path = indexed(at + ".waypoints", i);
      const int eline = line_of(e, wline);
      Waypoint wp;
      const Keys wk = read_table(c, e, path, eline, "waypoint", wp, {}, kWaypointRequired);
      wp.line = eline;
      if (wk.lines.count("direction"))
        wp.direction = unit_direction(c, wp.direction, wk.line_or("direction", eline), path + ".direction");
      if (!dev.waypoints.empty() && wp.t < dev.waypoints.back().t)
        c.fail(wk.line_or("t", eline), path + ".t",
               "time " + format_number(wp.t) + " s goes back (previous waypoint at " +
                   format_number(dev.waypoints.back().t) + " s); expected non-decreasing times");
      dev.waypoints.push_back(wp);
    }
    // Each waypoint is 88 bytes in the device (its pose and orientation); the YAML that listed them
    // took far more (load_scene's estimate refuses a file too large to parse before this).
    const double need = double(dev.waypoints.size()) * 88.0, memory = usable_memory_bytes();
    if (memory > 0 && need > 0.5 * memory)
      c.fail(wline, at + ".waypoints",
             fmt::format("{} waypoints need about {}, more than half of this machine's {} of memory; expected a "
                         "trajectory CSV (device.trajectory) or fewer waypoints",
                         dev.waypoints.size(), memory_text(need), memory_text(memory)));
  }
  if (!dev.trajectory.empty()) {
    if (!scripted)
      c.fail(k.line_or("trajectory", line), at + ".trajectory",
             "only a scripted device follows a trajectory (kind is '" + dev.kind + "')");
    if (!dev.waypoints.empty())
      c.fail(k.line_or("trajectory", line), at + ".trajectory",
             "give either 'waypoints' or 'trajectory', not both");
    require_file(c, dev.trajectory, k.line_or("trajectory", line), at + ".trajectory");
    // A row (~30 characters) becomes a 88-byte waypoint: refused when the file cannot fit.
    std::error_code ec;
    const double rows = double(fs::file_size(dev.trajectory, ec)) / 30.0, memory = usable_memory_bytes();
    if (!ec && memory > 0 && rows * 88.0 > 0.5 * memory)
      c.fail(k.line_or("trajectory", line), at + ".trajectory",
             fmt::format("{} is about {:.3g} rows, about {} as waypoints, more than half of this machine's {} of "
                         "memory; expected a shorter trajectory",
                         dev.trajectory.string(), rows, memory_text(rows * 88.0), memory_text(memory)));
  }
  if (dev.kind == "replay") {
    if (dev.recording.empty()) c.fail(line, at, "missing required key 'recording' (kind is 'replay')");
    require_file(c, dev.recording, k.line_or("recording", line), at + ".recording");
  } else if (!dev.recording.empty()) {
    c.fail(k.line_or("recording", line), at + ".recording",
           "only a replay device plays a recording (kind is '" + dev.kind + "')");
  }
  // forcedimension: one device, by its index or its serial number, not both.
  if (k.lines.count("dhd_index") && k.lines.count("dhd_serial"))
    c.fail(k.line_or("dhd_serial", line), at + ".dhd_serial",
           "give either 'dhd_index' or 'dhd_serial', not both (a serial number names one device)");
  return dev;
}

ProbeDef parse_probe(const Ctx& c, const YAML::Node& node, int line) {
  ProbeDef p;
  const Keys k = read_table(c, node, "probe", line, "probe", p, kProbeSections);
  p.axis = unit_direction(c, p.axis, k.line_or("axis", line), "probe.axis");
  p.lateral = unit_direction(c, p.lateral, k.line_or("lateral", line), "probe.lateral");
  if (std::abs(p.axis.dot(p.lateral)) > 1e-6)
    c.fail(k.line_or("lateral", line), "probe.lateral",
           "must be perpendicular to probe.axis (their dot product is " + format_number(p.axis.dot(p.lateral)) + ")");
  if (const auto d = k.sections.find("device"); d != k.sections.end())
    p.device = parse_device(c, d->second, k.value_line("device", line), "probe.device");
  return p;
}

GrasperDef parse_grasper(const Ctx& c, const YAML::Node& node, int line) {
  GrasperDef g;
  const Keys k = read_table(c, node, "grasper", line, "grasper", g, kGrasperSections);
  if (const auto d = k.sections.find("device"); d != k.sections.end())
    g.device = parse_device(c, d->second, k.value_line("device", line), "grasper.device");
  return g;
}

CameraDef parse_camera(const Ctx& c, const YAML::Node& node, int line) {
  CameraDef cam;
  const Keys k = read_table(c, node, "camera", line, "camera", cam);
  if ((cam.position - cam.target).norm() < 1e-9)
    c.fail(k.line_or("target", line), "camera.target", "must differ from camera.position");
  return cam;
}

// Keys of one model's material table, for telling a user a key belongs to the other model.
template <class Def>
bool has_key(const std::string& key) {
  for (const Param<Def>& p : param_table(static_cast<const Def*>(nullptr)))
    if (key == p.key) return true;
  return false;
}

TissueDef parse_tissue(const Ctx& c, const YAML::Node& node, size_t index, int list_line) {
  const std::string path = indexed("tissues", index);
  TissueDef t;
  t.line = line_of(node, list_line);
  const Keys k = read_table(c, node, path, t.line, "tissue", t, kTissueSections, kTissueRequired);
  if (t.name.empty()) c.fail(k.line_or("name", t.line), path + ".name", "expected a non-empty name");

  const auto patch = k.sections.find("patch");
  const auto mesh = k.sections.find("mesh");
  if (patch != k.sections.end() && mesh != k.sections.end())
    c.fail(k.line_or("mesh", t.line), path, "has both 'patch' and 'mesh'; expected exactly one");
  if (patch == k.sections.end() && mesh == k.sections.end())
    c.fail(t.line, path, "has neither 'patch' nor 'mesh'; expected exactly one");
  if (patch != k.sections.end()) {
    const int pline = k.value_line("patch", t.line);
    PatchDef p;
    const Keys pk = read_table(c, patch->second, path + ".patch", pline, "patch", p);
    p.normal = unit_direction(c, p.normal, pk.line_or("normal", pline), path + ".patch.normal");
    for (const char* side : {"width", "height"}) {
      const double extent = std::strcmp(side, "width") == 0 ? p.width : p.height;
      if (extent < p.spacing)
        c.fail(pk.line_or(side, pline), path + ".patch." + side,
               format_number(extent) + " m is less than the spacing " + format_number(p.spacing) +
                   " m; expected at least one spacing");
    }
    // What the patch will take to build, refused here when it cannot fit: a 1 m patch at 0.1 mm
    // spacing (1.2e8 particles, inside every key's range) died of SIGABRT after 6.7 s. About 300
    // bytes a particle at the peak of building (the model's and state's arrays, the neighbour
    // lists, the triangles and the drawn copies); the hexagonal lattice's rows are spacing·√3/2 apart.
    const double particles = (p.width / p.spacing + 1) * (p.height / (p.spacing * 0.8660254037844386) + 1);
    const double need = particles * 300.0;
    const double memory = usable_memory_bytes();
    if (memory > 0 && need > memory)
      c.fail(pk.line_or("spacing", pline), path + ".patch.spacing",
             "a " + format_number(p.width) + " m x " + format_number(p.height) + " m patch at " +
                 format_number(p.spacing) + " m spacing is about " + fmt_count(particles) + " particles, about " +
                 fmt_count(need * 1e-9) + " GB to build, more than this machine's " + fmt_count(memory * 1e-9) +
                 " GB of memory; expected a coarser spacing or a smaller patch");
    t.patch = p;
  } else {
    const int mline = k.value_line("mesh", t.line);
    MeshRef m;
    const Keys mk = read_table(c, mesh->second, path + ".mesh", mline, "mesh", m, {}, kMeshRequired);
    if (m.file.empty()) c.fail(mk.line_or("file", mline), path + ".mesh.file", "expected a file name, got ''");
    require_file(c, m.file, mk.line_or("file", mline), path + ".mesh.file");
    t.mesh = m;
  }

  const bool charged = t.model == "charged_particles";
  if (const auto mat = k.sections.find("material"); mat != k.sections.end()) {
    const int mline = k.value_line("material", t.line);
    const std::string mpath = path + ".material";
    Keys mk;
    if (charged) {
      mk = read_table(c, mat->second, mpath, mline, "charged_particles material", t.charged, {}, {},
                      [](const std::string& key) {
                        // Keys of the charged-particle model before its force became a law of the
                        // indentation (docs/models/charged-particles.md): say what replaced them.
                        if (key == "sphere_of_influence")
                          return std::string("'sphere_of_influence' is now the tool's radius plus 'particle_radius'");
                        if (key == "track_friction")
                          return std::string("'track_friction' (N) is now 'friction_per_length' (N/m) over the "
                                             "shaft inside 'thickness'");
                        return has_key<SpringMaterialDef>(key) ? "'" + key + "' is a mass_spring key" : std::string();
                      });
    } else {
      mk = read_table(c, mat->second, mpath, mline, "mass_spring material", t.spring, {}, {},
                      [](const std::string& key) {
                        return has_key<ChargedMaterialDef>(key) ? "'" + key + "' is a charged_particles key"
                                                                : std::string();
                      });
    }
    if (!charged) check_spring_rules(c, t.spring, mk, mline, mpath);
    if (charged && t.patch && t.charged.max_separation > 0 && !(t.charged.max_separation > t.patch->spacing))
      c.fail(mk.line_or("max_separation", mline), mpath + ".max_separation",
             format_number(t.charged.max_separation) + " m must exceed the patch spacing " +
                 format_number(t.patch->spacing) + " m (or leave it 0 and set max_strain)");
  }
  if (!t.spring.predictor.empty()) t.spring.predictor = c.resolve(t.spring.predictor).string();

  if (const auto a = k.sections.find("anchors"); a != k.sections.end()) {
    const int aline = k.value_line("anchors", t.line);
    if (!a->second.IsSequence())
      c.fail(aline, path + ".anchors", "expected a list of vertex or particle indices, got " + describe(a->second));
    // Duplicates found through a hash set: a linear search per anchor took 97 s for 1M anchors.
    std::unordered_set<int> seen;
    seen.reserve(a->second.size());
    t.anchors.reserve(a->second.size());
    size_t i = 0;
    for (const YAML::Node& e : a->second) {  // iterating: a sequence's operator[] is linear
      const std::string epath = indexed(path + ".anchors", i++);
      const int v = read_int(c, e, epath, line_of(e, aline), 0, std::numeric_limits<int>::max(), "");
      if (!seen.insert(v).second) c.fail(line_of(e, aline), epath, std::to_string(v) + " is listed twice");
      t.anchors.push_back(v);
    }
  }
  return t;
}

// A needle goes in and out along its shaft. A scripted segment that advances or withdraws it more
// than 15° off its own axis over more than 1 mm drags the tissues it is in sideways, off the track
// its puncture made (issue 35: a 70° path with tool.axis left at 45° reported `exit fat` 13.8 mm
// deep): it loads and runs as written, with a warning that names the waypoint and what to do. A
// move at 75° or more to the shaft is taken for a move to the next site above the skin (the scene
// file does not say where the skin is: needle-60s.yaml's steps between insertions), not warned.
constexpr double kSidewaysWarning = 15.0;  // degrees
constexpr double kRepositioning = 75.0;    // degrees
constexpr double kSidewaysMinimum = 0.001; // m

std::vector<std::string> path_warnings(const SceneDef& s, const std::string& name) {
  std::vector<std::string> out;
  if (s.tool.kind != "needle" || s.device.kind != "scripted" || !(s.tool.axis.norm() > 0)) return out;
  Vec3 axis = s.tool.axis.normalized();
  const std::vector<Waypoint>& w = s.device.waypoints;
  for (size_t k = 0; k < w.size(); ++k) {
    const Vec3 next = w[k].direction.isZero() ? axis : Vec3(w[k].direction.normalized());
    if (k > 0) {
      const Vec3 d = w[k].position - w[k - 1].position;
      const double len = d.norm();
      if (len > kSidewaysMinimum) {
        // Between two waypoints the needle turns from one direction to the next: the smaller
        // angle to either is the most the path can be excused.
        const double c = std::max(std::abs(d.dot(axis)), std::abs(d.dot(next))) / len;
        const double angle = std::acos(std::min(1.0, c)) * 180.0 / 3.14159265358979323846;
        if (angle > kSidewaysWarning && angle < kRepositioning)
          out.push_back(fmt::format(
              "{}:{}: device.waypoints[{}]: the needle moves {:.1f} mm at {:.0f}° to its own shaft between t = {} s "
              "and {} s; a needle goes in and out along its shaft, and moved sideways it drags the tissues it is in "
              "off the track it made: aim the path along tool.axis ({}, {}, {}), or give the waypoints a direction",
              name, w[k].line, k, len * 1e3, angle, format_number(w[k - 1].t), format_number(w[k].t),
              format_number(axis.x()), format_number(axis.y()), format_number(axis.z())));
      }
    }
    axis = next;
  }
  return out;
}

// The value under `key` in a mapping (an undefined node when it has none or is not a mapping).
YAML::Node child(const YAML::Node& map, const char* key) {
  if (map.IsMap())
    for (auto it = map.begin(); it != map.end(); ++it)
      if (it->first.IsScalar() && it->first.Scalar() == key) return it->second;
  return YAML::Node(YAML::NodeType::Undefined);
}

// Two openhaptics tools on one HD device configuration (both on the default one, "", too) would
// be two safety filters on one arm, and the HD library refuses the second (HD_DEVICE_ALREADY_
// INITIATED): refused here, naming the key and the one that has it.
void check_hd_devices(const Ctx& c, const Keys& k, const SceneDef& s) {
  struct Use {
    std::string key;
    const DeviceDef* def;
    int line;  // of its hd_device key, else of its device section
  };
  std::vector<Use> uses;
  const auto add = [&](const std::string& key, const DeviceDef& def, const YAML::Node& section,
                       int section_line) {
    if (def.kind != "openhaptics") return;
    int line = section_line;
    if (section.IsMap())
      for (auto it = section.begin(); it != section.end(); ++it)
        if (it->first.IsScalar() && it->first.Scalar() == "hd_device")
          line = line_of(it->first, section_line);
    uses.push_back({key, &def, line});
  };
  if (const auto n = k.sections.find("device"); n != k.sections.end())
    add("device.hd_device", s.device, n->second, k.value_line("device", 1));
  for (const char* tool : {"probe", "grasper"}) {
    const auto n = k.sections.find(tool);
    const DeviceDef* def = s.probe && std::string(tool) == "probe"       ? &s.probe->device
                           : s.grasper && std::string(tool) == "grasper" ? &s.grasper->device
                                                                         : nullptr;
    if (n == k.sections.end() || !def) continue;
    const YAML::Node dev = child(n->second, "device");
    const int line = k.value_line(tool, 1);
    add(std::string(tool) + ".device.hd_device", *def, dev,
        dev.IsDefined() ? line_of(dev, line) : line);
  }
  for (size_t i = 1; i < uses.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (uses[i].def->hd_device == uses[j].def->hd_device)
        c.fail(uses[i].line, uses[i].key,
               (uses[i].def->hd_device.empty() ? std::string("the default device (\"\")")
                                               : "'" + uses[i].def->hd_device + "'") +
                   " is already used by " + uses[j].key + " (line " + std::to_string(uses[j].line) +
                   "); each openhaptics tool needs its own device: name the configurations "
                   "Touch Setup gave your devices");
}

SceneDef parse_root(const Ctx& c, const YAML::Node& root) {
  SceneDef s;
  const Keys k = read_table(c, root, "", 1, "scene", s, kSceneSections);
  if (s.dt > s.duration)
    c.fail(k.line_or("dt", k.line_or("duration", 1)), "dt",
           format_number(s.dt) + " s exceeds duration " + format_number(s.duration) + " s; expected dt <= duration");
  if (s.output.empty()) c.fail(k.line_or("output", 1), "output", "expected a directory, got ''");
  s.output = c.resolve(s.output);
  if (const auto n = k.sections.find("tool"); n != k.sections.end())
    s.tool = parse_tool(c, n->second, k.value_line("tool", 1));
  if (const auto n = k.sections.find("device"); n != k.sections.end())
    s.device = parse_device(c, n->second, k.value_line("device", 1));
  if (const auto n = k.sections.find("camera"); n != k.sections.end())
    s.camera = parse_camera(c, n->second, k.value_line("camera", 1));
  if (const auto n = k.sections.find("probe"); n != k.sections.end())
    s.probe = parse_probe(c, n->second, k.value_line("probe", 1));
  if (const auto n = k.sections.find("grasper"); n != k.sections.end()) {
    s.grasper = parse_grasper(c, n->second, k.value_line("grasper", 1));
    if (s.probe)
      c.fail(k.value_line("grasper", 1), "grasper",
             "a scene has one second tool: the other hand holds the ultrasound probe (section 'probe') or a "
             "grasper, not both");
  }
  check_hd_devices(c, k, s);

  // The anatomy is read here and generated by the Simulation's build (expand_anatomy): its tissues'
  // materials may be changed per layer, each key range-checked now against its table row.
  if (const auto n = k.sections.find("anatomy"); n != k.sections.end()) {
    const int aline = k.value_line("anatomy", 1);
    NeckDef neck;
    const Keys ak = read_table(c, n->second, "anatomy", aline, "anatomy", neck, kAnatomySections);
    neck.file = c.name;
    neck.line = aline;
    if (const auto layers = ak.sections.find("layers"); layers != ak.sections.end()) {
      const int lline = ak.value_line("layers", aline);
      if (!layers->second.IsMap())
        c.fail(lline, "anatomy.layers", "expected a mapping of layer names (skin, fat, ijv, cca) to materials, got " +
                                            describe(layers->second));
      for (auto it = layers->second.begin(); it != layers->second.end(); ++it) {
        AnatomyLayerDef layer;
        layer.line = line_of(it->first, lline);
        layer.name = it->first.IsScalar() ? it->first.Scalar() : std::string();
        const std::string lpath = "anatomy.layers." + layer.name;
        if (std::find_if(std::begin(kNeckLayers), std::end(kNeckLayers),
                         [&](const char* l) { return layer.name == l; }) == std::end(kNeckLayers))
          c.fail(layer.line, lpath, "not a layer of the neck; expected skin, fat, ijv or cca");
        for (const AnatomyLayerDef& other : neck.layers)
          if (other.name == layer.name)
            c.fail(layer.line, lpath, "duplicate layer (first on line " + std::to_string(other.line) + ")");
        const Keys mk = read_table(c, it->second, lpath, line_of(it->second, layer.line), "charged_particles material",
                                   layer.material, {}, {}, [](const std::string& key) {
                                     return has_key<SpringMaterialDef>(key)
                                                ? "'" + key + "' is a mass_spring key; the neck's layers are charged_particles"
                                                : std::string();
                                   });
        for (const auto& [key, kl] : mk.lines) layer.keys.push_back(key);
        neck.layers.push_back(std::move(layer));
      }
    }
    s.anatomy = neck;
  }
  if (s.probe && !s.anatomy)
    c.fail(k.value_line("probe", 1), "probe", "needs an 'anatomy': the ultrasound images the generated neck");
  const auto tl = k.sections.find("tissues");
  if (tl == k.sections.end()) {
    if (!s.anatomy) c.fail(1, "tissues", "missing; expected a list of tissues, or an 'anatomy' that generates them");
    return s;
  }
  const YAML::Node list = tl->second;
  const int lline = k.value_line("tissues", 1);
  if (!list.IsSequence() || (list.size() == 0 && !s.anatomy))
    c.fail(lline, "tissues", "expected a non-empty list of tissues, got " + describe(list));
  for (size_t i = 0; i < list.size(); ++i) {
    TissueDef t = parse_tissue(c, list[i], i, lline);
    if (s.anatomy)
      for (const char* layer : kNeckLayers)
        if (t.name == layer)
          c.fail(t.line, indexed("tissues", i) + ".name",
                 "duplicate tissue name '" + t.name + "' (first on line " + std::to_string(s.anatomy->line) +
                     ": the anatomy generates it)");
    for (const TissueDef& other : s.tissues)
      if (other.name == t.name)
        c.fail(t.line, indexed("tissues", i) + ".name",
               "duplicate tissue name '" + t.name + "' (first on line " + std::to_string(other.line) + ")");
    s.tissues.push_back(std::move(t));
  }
  return s;
}

// Where each YAML document of a stream starts, at most `limit` of them — the events only, no nodes.
// yaml-cpp 0.7's LoadAll never returns on a stream whose document opens with a token no node can
// start with (a lone ','): its parser reports a null document without consuming the token, again
// and again, each one appended to the result until memory runs out (found by fuzzing; yaml-cpp
// issue 1040, fixed upstream in 0.8.0 by stopping at such a document). Counting a bounded number
// of documents and comparing where they start finds it: a document that starts where the one
// before it started consumed nothing.
// Each document: where it starts (its first token, `---` when it has one) and its root node.
struct DocumentMarks {
  YAML::Mark start, root = YAML::Mark::null_mark();
};

class DocumentStarts final : public YAML::EventHandler {
 public:
  std::vector<DocumentMarks> docs;
  void OnDocumentStart(const YAML::Mark& mark) override { docs.push_back({mark}); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t) override { node(m); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t) override { node(m); }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t, const std::string&) override { node(m); }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(m);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(m);
  }
  void OnMapEnd() override {}

 private:
  void node(const YAML::Mark& m) {
    if (!docs.empty() && docs.back().root.is_null()) docs.back().root = m;
  }
};

std::vector<DocumentMarks> document_starts(const std::string& yaml, size_t limit) {
  std::istringstream in(yaml);
  YAML::Parser parser(in);
  DocumentStarts events;
  while (events.docs.size() < limit && parser.HandleNextDocument(events)) {
  }
  return events.docs;
}

}  // namespace

Result<SceneDef> parse_scene(const std::string& yaml, const std::string& name, const fs::path& base_dir) {
  const Ctx c{name, base_dir};
  try {
    YAML::Node root;
    try {
      // One document, and only one (not YAML::LoadAll: see document_starts).
      const std::vector<DocumentMarks> docs = document_starts(yaml, 2);
      if (docs.size() > 1) {
        const YAML::Mark& at = docs[0].start;
        if (docs[1].start.pos == at.pos)
          return Error{fmt::format("{}:{}: YAML syntax error: '{}' cannot start a document (column {})", name,
                                   at.line + 1, at.pos >= 0 && size_t(at.pos) < yaml.size() ? yaml[size_t(at.pos)] : '?',
                                   at.column + 1)};
        const YAML::Mark& second = docs[1].root.is_null() ? docs[1].start : docs[1].root;
        c.fail(second.line + 1, "", "a second YAML document starts here; expected one scene per file");
      }
      if (!docs.empty()) root = YAML::Load(yaml);
    } catch (const YAML::ParserException& e) {
      std::string m = name;
      if (e.mark.line >= 0) m += ":" + std::to_string(e.mark.line + 1);
      m += ": YAML syntax error: " + e.msg;
      if (e.mark.column >= 0) m += " (column " + std::to_string(e.mark.column + 1) + ")";
      return Error{m};
    }
    if (!root.IsDefined() || root.IsNull())
      return Error{name + ": the scene is empty; expected a mapping with at least the key 'tissues'"};
    if (!root.IsMap())
      c.fail(line_of(root, 1), "", "expected a mapping of scene keys at the top level, got " + describe(root));
    SceneDef scene = parse_root(c, root);
    scene.warnings = path_warnings(scene, name);
    return scene;
  } catch (const ParseFailure& f) {
    return Error{f.message};
  } catch (const YAML::Exception& e) {
    // Not expected (the reader checks node types before use); still a message, never a crash.
    return Error{name + ": " + e.what()};
  }
}

Result<SceneDef> load_scene(const fs::path& file) {
  std::error_code ec;
  // /dev/zero would be read until memory runs out, a FIFO would block the open: stat first.
  if (Status s = check_regular_file(file, "a YAML scene file"); !s) return s.error();
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error{file.string() + ": cannot open scene file (" + std::strerror(errno) + ")"};
  // The YAML parser holds about 75 bytes of nodes per byte of the file (3.9 GB for a 52 MB scene of
  // 1,000,000 waypoints, and 3 minutes): a scene too large to parse is refused before it is read.
  const auto size = fs::file_size(file, ec);
  const double memory = usable_memory_bytes();
  if (!ec && memory > 0 && double(size) * 80.0 > memory) {
    size_t lines = 0;
    for (std::string l; std::getline(in, l);) ++lines;
    return Error{fmt::format("{}: {} in {} lines is about {} to parse, more than this machine's {} of memory; "
                             "long paths belong in a trajectory CSV (device.trajectory: t,x,y,z rows, 88 bytes a "
                             "waypoint) rather than device.waypoints",
                             file.string(), memory_text(double(size)), lines, memory_text(double(size) * 80.0),
                             memory_text(memory))};
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Error{file.string() + ": cannot read scene file"};
  const fs::path base = fs::absolute(file, ec).parent_path();
  Result<SceneDef> scene = parse_scene(text.str(), file.string(), ec ? file.parent_path() : base);
  if (scene) scene->file = file;
  return scene;
}

}  // namespace palpate
