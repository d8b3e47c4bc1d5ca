// export_run.cpp — RunExporter: a run's saved states as VTU grids + PVD and as an animated glTF
// scene (docs/export.md). Plain arrays are made here from the snapshots (the charged layers'
// Bézier surfaces through the surface layer); io writes the files.
#include "simulation/export_run.h"

#include <palpate/simulation.h>
#include <palpate/spring.h>
#include <palpate/surface.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <system_error>
#include <unistd.h>

namespace palpate {

namespace {

// The role's code in the "role" point array (docs/export.md).
int role_code(const std::string& role) {
  static const char* const kRoles[] = {"tissue", "skin", "fat", "muscle", "vein", "artery", "organ"};
  for (size_t i = 0; i < std::size(kRoles); ++i)
    if (role == kRoles[i]) return int(i);
  return 0;
}

std::array<float, 4> role_rgba(const std::string& role) {
  if (role == "skin") return {0.91f, 0.70f, 0.58f, 0.45f};
  if (role == "fat") return {0.96f, 0.84f, 0.40f, 0.25f};
  if (role == "muscle") return {0.62f, 0.24f, 0.22f, 1.0f};
  if (role == "vein") return {0.22f, 0.17f, 0.72f, 0.9f};
  if (role == "artery") return {0.90f, 0.08f, 0.10f, 0.9f};
  if (role == "organ") return {0.60f, 0.22f, 0.18f, 1.0f};
  return {0.85f, 0.55f, 0.50f, 1.0f};
}

// A file name's safe form of a tissue's name.
std::string file_stem(const std::string& name) {
  std::string s;
  for (char c : name) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return s.empty() ? std::string("tissue") : s;
}

// Proves `dir` exists (made if missing) and takes a new file, naming the path when it does not.
Status check_writable(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{dir.string() + ": cannot make the export folder: " + ec.message()};
  const std::filesystem::path probe = dir / fmt::format(".palpate-export-probe-{}", ::getpid());
  {
    std::ofstream f(probe);
    if (!f) return Error{dir.string() + ": the export folder is not writable (cannot create a file in it)"};
  }
  std::filesystem::remove(probe, ec);
  return {};
}

}  // namespace

// One tissue: how its snapshot becomes a grid and a glTF surface.
struct RunExporter::Part {
  std::string name, stem, role;
  int index = 0;
  std::optional<SurfaceTessellator> tess;     // a control grid: its Bézier surface is what is exported
  std::vector<std::array<int, 4>> tets;       // a mass-spring body's tetrahedra (cells), when it has them
  std::vector<std::array<int, 3>> triangles;  // otherwise its triangles
  std::vector<float> rest;                    // (n x 3) the exported points at rest
  std::vector<std::uint32_t> surface_tris;    // glTF: the drawn surface's triangles over the exported points
  std::vector<std::int32_t> nearest;          // Bézier: each surface point's nearest control particle
  int gltf = -1;
  SurfaceBuffers buf;                         // scratch
};

RunExporter::~RunExporter() = default;

Result<std::unique_ptr<RunExporter>> RunExporter::open(Simulation& sim, const std::vector<std::string>& formats,
                                                       const std::filesystem::path& out, int resolution,
                                                       std::span<const TissueSnapshot> rest) {
  std::unique_ptr<RunExporter> e(new RunExporter());
  for (const std::string& f : formats) {
    if (f == "vtu") e->vtu_ = true;
    else if (f == "gltf") e->gltf_ = true;
    else return Error{"exports: '" + f + "' is not an export format (vtu, gltf)"};
  }
  e->out_ = out;
  if (Status s = check_writable(out); !s) return s.error();
  std::error_code ec;
  if (e->vtu_) {
    if (Status s = check_writable(out / "vtu"); !s) return s.error();
    for (const auto& f : std::filesystem::directory_iterator(out / "vtu", ec))  // an earlier run's
      if (f.path().extension() == ".vtu") std::filesystem::remove(f.path(), ec);
    std::filesystem::remove(out / "run.pvd", ec);
  }
  if (e->gltf_) {
    std::filesystem::remove(out / "run.glb", ec);
    e->gltf_scene_ = std::make_unique<GltfScene>();
  }
  const SceneDef& scene = sim.scene();
  const size_t n = sim.tissue_count();
  if (rest.size() != n) return Error{"exports: need every tissue's snapshot (a simulation built with snapshots)"};
  std::vector<std::string> stems;
  for (size_t i = 0; i < n; ++i) {
    auto p = std::make_unique<Part>();
    p->name = sim.tissue(i).name();
    p->index = int(i);
    p->role = i < scene.tissues.size() ? scene.tissues[i].role : "tissue";
    p->stem = file_stem(p->name);
    while (std::find(stems.begin(), stems.end(), p->stem) != stems.end()) p->stem += "_";
    stems.push_back(p->stem);
    const TissueSnapshot& r = rest[i];
    if (r.rows_cols.size() == 2 && r.rows_cols[0] >= 2 && r.rows_cols[1] >= 2) {
      SurfaceDef def;
      def.resolution = std::max(1, resolution);
      auto tess = SurfaceTessellator::build(r.rows_cols[0], r.rows_cols[1], def);
      if (!tess) return tess.error();
      p->tess = std::move(*tess);
      if (!p->tess->tessellate(r.points, p->buf)) return Error{"exports: tissue '" + p->name + "': snapshot does not fit its grid"};
      p->rest = p->buf.positions;
      p->surface_tris.assign(p->tess->triangles().begin(), p->tess->triangles().end());
      // Each surface point's nearest control particle (by parameter): its "punctured" flag.
      const int rows = r.rows_cols[0], cols = r.rows_cols[1], res = def.resolution;
      const size_t per = size_t(res + 1) * size_t(res + 1);
      for (size_t k = 0; k < p->buf.point_count(); ++k) {
        const int patch = int(k / per), local = int(k % per);
        const int pi = patch / p->tess->patch_cols(), pj = patch % p->tess->patch_cols();
        const int a = local / (res + 1), b = local % (res + 1);  // a along v (rows), b along u (columns)
        const int row = std::min(rows - 1, 3 * pi + int(std::lround(3.0 * a / res)));
        const int col = std::min(cols - 1, 3 * pj + int(std::lround(3.0 * b / res)));
        p->nearest.push_back(row * cols + col);
      }
    } else {
      p->rest.reserve(3 * r.points.size());
      for (const Vec3f& q : r.points) p->rest.insert(p->rest.end(), {q.x(), q.y(), q.z()});
      if (const SpringBody* body = sim.tissue(i).spring_body(); body && body->model) p->tets = body->model->network.tets;
      p->triangles = r.triangles;
      for (const auto& t : r.triangles) p->surface_tris.insert(p->surface_tris.end(), {std::uint32_t(t[0]), std::uint32_t(t[1]), std::uint32_t(t[2])});
    }
    if (e->gltf_ && !p->surface_tris.empty()) p->gltf = e->gltf_scene_->add_surface(p->name, p->surface_tris, role_rgba(p->role));
    e->parts_.push_back(std::move(p));
  }
  for (const SimulationTool& t : sim.tools()) {
    e->tool_names_.push_back(t.name);
    std::string kind = t.role == ToolRole::ultrasound_probe ? "box"
                       : t.role == ToolRole::needle       ? "needle"
                       : t.role == ToolRole::blade        ? "blade"
                                                          : "sphere";
    e->tool_kinds_.push_back(kind);
    e->tool_radius_.push_back(t.role == ToolRole::grasper && scene.grasper ? scene.grasper->radius : scene.tool.radius);
    e->tool_length_.push_back(kind == "needle" || kind == "blade" ? scene.tool.length : 0.0);
    if (e->gltf_) {
      if (kind == "box" && scene.probe) {
        const ProbeDef& pd = *scene.probe;
        const Vec3 lat = pd.lateral.normalized(), ax = pd.axis.normalized(), el = lat.cross(ax).normalized();
        const double h = 0.08;  // m, how tall the box stands (as frames draw it)
        const Vec3 half = (lat * (pd.width / 2)).cwiseAbs() + (ax * (h / 2)).cwiseAbs() + (el * (pd.thickness / 2)).cwiseAbs();
        e->gltf_scene_->add_tool(t.name, "box", 0, h, ax, half, {0.75f, 0.78f, 0.82f, 1.0f});
      } else {
        e->gltf_scene_->add_tool(t.name, kind, e->tool_radius_.back(), e->tool_length_.back(), t.axis, Vec3::Zero(),
                                 {0.80f, 0.82f, 0.86f, 1.0f});
      }
    }
  }
  e->tool_first_.assign(e->tool_names_.size(), Vec3::Zero());
  e->tool_seen_.assign(e->tool_names_.size(), false);
  return e;
}

ExportGrid RunExporter::tissue_grid(size_t i, const TissueSnapshot& snap, double time, Status& status) {
  Part& p = *parts_[i];
  ExportGrid g;
  const bool bezier = p.tess.has_value();
  std::vector<float> pts;
  if (bezier) {
    if (!p.tess->tessellate(snap.points, p.buf)) {
      status = Error{"exports: tissue '" + p.name + "': snapshot does not fit its grid"};
      return g;
    }
    pts = p.buf.positions;
  } else {
    pts.reserve(3 * snap.points.size());
    for (const Vec3f& q : snap.points) pts.insert(pts.end(), {q.x(), q.y(), q.z()});
  }
  const size_t n = pts.size() / 3;
  if (pts.size() != p.rest.size()) {
    status = Error{"exports: tissue '" + p.name + "': " + std::to_string(n) + " points, " +
                   std::to_string(p.rest.size() / 3) + " at rest (the topology changed)"};
    return g;
  }
  g.points.assign(pts.begin(), pts.end());
  ExportArray disp{"displacement", 3, false, {}}, vel{"velocity", 3, false, {}}, force{"force", 3, false, {}};
  ExportArray punct{"punctured", 1, true, {}}, role{"role", 1, true, {}};
  disp.values.resize(3 * n);
  for (size_t k = 0; k < 3 * n; ++k) disp.values[k] = double(pts[k]) - double(p.rest[k]);
  vel.values.assign(3 * n, 0.0);
  force.values.assign(3 * n, 0.0);
  if (!bezier && snap.velocities.size() == n)
    for (size_t k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) vel.values[3 * k + size_t(c)] = snap.velocities[k][c];
  if (!bezier && snap.loads.size() == n)
    for (size_t k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) force.values[3 * k + size_t(c)] = snap.loads[k][c];
  punct.values.assign(n, 0.0);
  if (bezier && snap.punctured.size() == snap.points.size())
    for (size_t k = 0; k < n; ++k) punct.values[k] = snap.punctured[size_t(p.nearest[k])];
  else if (snap.punctured.size() == n)
    for (size_t k = 0; k < n; ++k) punct.values[k] = snap.punctured[k];
  role.values.assign(n, double(role_code(p.role)));
  g.point_data = {std::move(disp), std::move(vel), std::move(force), std::move(punct), std::move(role)};
  g.field_data.push_back({"TimeValue", 1, false, {time}});
  g.field_data.push_back({"tissue_index", 1, false, {double(p.index)}});
  if (bezier) {
    const auto tris = p.tess->triangles();
    for (size_t t = 0; t + 2 < tris.size(); t += 3) {
      const std::int64_t ids[3] = {tris[t], tris[t + 1], tris[t + 2]};
      g.add_cell(kVtkTriangle, ids);
    }
  } else if (!p.tets.empty()) {
    for (const auto& t : p.tets) {
      const std::int64_t ids[4] = {t[0], t[1], t[2], t[3]};
      g.add_cell(kVtkTetra, ids);
    }
  } else if (!p.triangles.empty()) {
    for (const auto& t : p.triangles) {
      const std::int64_t ids[3] = {t[0], t[1], t[2]};
      g.add_cell(kVtkTriangle, ids);
    }
  } else {
    for (size_t k = 0; k < n; ++k) {
      const std::int64_t id = std::int64_t(k);
      g.add_cell(kVtkVertex, std::span<const std::int64_t>(&id, 1));
    }
  }
  return g;
}

Status RunExporter::write_tools(size_t k, double time, std::span<const ExportToolSample> tools) {
  // A needle as its shaft (tip, then the hub), a blade as its cutting edge (tip, then the heel), a
  // sphere or the probe as a point.
  ExportGrid g;
  ExportArray disp{"displacement", 3, false, {}}, vel{"velocity", 3, false, {}}, force{"force", 3, false, {}};
  ExportArray punct{"punctured", 1, true, {}}, role{"role", 1, true, {}};
  for (size_t t = 0; t < tools.size() && t < tool_names_.size(); ++t) {
    const ExportToolSample& s = tools[t];
    if (!s.valid) continue;
    if (!tool_seen_[t]) tool_first_[t] = s.position, tool_seen_[t] = true;
    std::vector<Vec3> pts = {s.position};
    if ((tool_kinds_[t] == "needle" || tool_kinds_[t] == "blade") && tool_length_[t] > 0) pts.push_back(s.position - s.axis.normalized() * tool_length_[t]);
    const std::int64_t base = std::int64_t(g.point_count());
    for (const Vec3& q : pts) {
      g.points.insert(g.points.end(), {q.x(), q.y(), q.z()});
      const Vec3 d = s.position - tool_first_[t];
      disp.values.insert(disp.values.end(), {d.x(), d.y(), d.z()});
      vel.values.insert(vel.values.end(), {0.0, 0.0, 0.0});
      force.values.insert(force.values.end(), {s.force.x(), s.force.y(), s.force.z()});
      punct.values.push_back(0);
      role.values.push_back(-1.0 - double(t));  // tools: −1 the scene's tool, −2 the probe
    }
    if (pts.size() == 2) {
      const std::int64_t ids[2] = {base, base + 1};
      g.add_cell(kVtkLine, ids);
    } else {
      g.add_cell(kVtkVertex, std::span<const std::int64_t>(&base, 1));
    }
  }
  g.point_data = {std::move(disp), std::move(vel), std::move(force), std::move(punct), std::move(role)};
  g.field_data.push_back({"TimeValue", 1, false, {time}});
  const std::string name = fmt::format("tools_{:0{}}.vtu", k, digits_);
  if (Status s = write_vtu(out_ / "vtu" / name, g); !s) return s;
  written_.push_back(out_ / "vtu" / name);
  return {};
}

Status RunExporter::add(double time, std::span<const TissueSnapshot> tissues, std::span<const ExportToolSample> tools) {
  if (tissues.size() != parts_.size()) return Error{"exports: a frame with the wrong number of tissues"};
  const size_t k = count_++;
  std::filesystem::path first;
  if (vtu_) {
    for (size_t i = 0; i < parts_.size(); ++i) {
      Status st;
      ExportGrid g = tissue_grid(i, tissues[i], time, st);
      if (!st) return st;
      const std::string name = fmt::format("{}_{:0{}}.vtu", parts_[i]->stem, k, digits_);
      if (Status s = write_vtu(out_ / "vtu" / name, g); !s) return s;
      written_.push_back(out_ / "vtu" / name);
      pvd_.push_back({time, int(i), parts_[i]->name, "vtu/" + name});
      if (first.empty()) first = out_ / "vtu" / name;
    }
    // The tools: before the first tick (t = 0) no tool has a pose; their file is written with the
    // first pose the run gives them (docs/export.md).
    const std::string name = fmt::format("tools_{:0{}}.vtu", k, digits_);
    pvd_.push_back({time, int(parts_.size()), "tools", "vtu/" + name});
    bool valid = !tools.empty();
    for (const ExportToolSample& s : tools) valid = valid && s.valid;
    if (!valid) {
      pending_tools_.push_back({k, time});
    } else {
      if (Status s = first_pose(tools); !s) return s;
      if (Status s = write_tools(k, time, tools); !s) return s;
    }
    if (first.empty()) first = out_ / "vtu" / name;
  }
  if (gltf_) {
    std::vector<std::vector<float>> surfaces;
    for (size_t i = 0; i < parts_.size(); ++i) {
      Part& p = *parts_[i];
      if (p.gltf < 0) continue;
      if (p.tess) {
        if (!p.tess->tessellate(tissues[i].points, p.buf)) return Error{"exports: tissue '" + p.name + "': snapshot does not fit its grid"};
        surfaces.push_back(p.buf.positions);
      } else {
        std::vector<float> pts;
        for (const Vec3f& q : tissues[i].points) pts.insert(pts.end(), {q.x(), q.y(), q.z()});
        surfaces.push_back(std::move(pts));
      }
    }
    bool valid = !tools.empty();
    for (const ExportToolSample& s : tools) valid = valid && s.valid;
    if (!valid) {  // t = 0: no pose yet; the frame waits for the first one (first_pose)
      gltf_held_.push_back(std::move(surfaces));
      gltf_held_time_ = time;
      gltf_waiting_ = true;
    } else {
      if (Status s = first_pose(tools); !s) return s;
      std::vector<Vec3> pos;
      std::vector<Quat> rot;
      for (const ExportToolSample& s : tools) pos.push_back(s.position), rot.push_back(s.orientation);
      gltf_scene_->add_frame(time, surfaces, pos, rot);
    }
    if (first.empty()) first = out_ / "run.glb";
  }
  saved_.push_back({time, first});
  return {};
}

Status RunExporter::first_pose(std::span<const ExportToolSample> tools) {
  for (const ExportToolSample& s : tools)
    if (!s.valid) return {};
  for (const auto& [pk, pt] : pending_tools_)
    if (Status s = write_tools(pk, pt, tools); !s) return s;
  pending_tools_.clear();
  if (gltf_waiting_) {
    std::vector<Vec3> pos;
    std::vector<Quat> rot;
    for (const ExportToolSample& s : tools) pos.push_back(s.position), rot.push_back(s.orientation);
    for (auto& held : gltf_held_) gltf_scene_->add_frame(gltf_held_time_, held, pos, rot);
    gltf_held_.clear();
    gltf_waiting_ = false;
  }
  return {};
}

Status RunExporter::finish(std::vector<std::filesystem::path>& files) {
  if (vtu_) {
    for (const auto& [pk, pt] : pending_tools_)  // no tool ever had a pose (no tick ran): no points
      if (Status s = write_tools(pk, pt, {}); !s) return s;
    pending_tools_.clear();
    if (Status s = write_pvd(out_ / "run.pvd", pvd_); !s) return s;
    files.push_back(out_ / "run.pvd");
    files.insert(files.end(), written_.begin(), written_.end());
  }
  if (gltf_) {
    if (gltf_waiting_) {  // no tool ever had a pose (a run of no ticks): the tools stay at the origin
      std::vector<Vec3> pos(tool_names_.size(), Vec3::Zero());
      std::vector<Quat> rot(tool_names_.size(), Quat::Identity());
      for (auto& held : gltf_held_) gltf_scene_->add_frame(gltf_held_time_, held, pos, rot);
      gltf_held_.clear();
      gltf_waiting_ = false;
    }
    if (Status s = gltf_scene_->write_glb(out_ / "run.glb"); !s) return s;
    files.push_back(out_ / "run.glb");
  }
  return {};
}

}  // namespace palpate
