// cmd_info.cpp — `palpate info FILE`: what a mesh holds and whether a model can use it.
#include <palpate/palpate.h>
#include <palpate/mesh_load.h>

#include "commands.h"

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <filesystem>

namespace palpate::cli {

namespace {

// The same figures as one JSON object (SI lengths after --scale), for scripts.
void print_json(const std::string& file, const MeshInfo& info) {
  auto vec = [](const Vec3& v) { return nlohmann::ordered_json::array({v.x(), v.y(), v.z()}); };
  nlohmann::ordered_json j;
  j["file"] = file;
  j["kind"] = info.kind;
  j["vertices"] = info.vertices;
  j["triangles"] = info.triangles;
  if (info.kind == "tetrahedral") j["tetrahedra"] = info.tetrahedra;
  j["bbox_min"] = vec(info.bbox_min);
  j["bbox_max"] = vec(info.bbox_max);
  j["size"] = vec(info.bbox_max - info.bbox_min);
  j["closed"] = info.closed;
  j["boundary_edges"] = info.boundary_edges;
  j["manifold"] = info.manifold;
  j["non_manifold_edges"] = info.non_manifold_edges;
  // The volume is the tetrahedra's sum or the enclosed one; none for an open surface.
  if (info.kind == "tetrahedral" || info.closed) j["volume"] = info.volume;
  else j["volume"] = nullptr;
  j["edges"] = {{"count", info.edges.count}, {"min", info.edges.min}, {"mean", info.edges.mean},
                {"median", info.edges.median}, {"max", info.edges.max}};
  fmt::print("{}\n", j.dump(2));
}

struct InfoArgs {
  std::string file;
  double scale = 1.0;
  bool json = false, quiet = false, verbose = false;
};

int info_command(const InfoArgs& a) {
  const std::string& file = a.file;
  const double scale = a.scale;
  MeshInfo info;
  if (is_tet_file(file)) {
    auto m = load_tet(file, scale);
    if (!m) {
      fmt::print(stderr, "palpate info: {}\n", m.error().message);
      return kExitFailed;
    }
    info = describe(*m);
  } else {
    auto m = load_surface(file, scale);
    if (!m) {
      fmt::print(stderr, "palpate info: {}\n", m.error().message);
      return kExitFailed;
    }
    info = describe(*m);
  }
  if (a.quiet) return kExitOk;  // the exit status says whether the mesh loads
  if (a.json) {
    print_json(file, info);
    return kExitOk;
  }
  if (a.verbose)
    fmt::print("loaded      {} ({} reader)\n", std::filesystem::absolute(file).string(),
               is_tet_file(file) ? "tetrahedral" : "surface");
  fmt::print("file        {}\n", file);
  fmt::print("kind        {}\n", info.kind);
  fmt::print("vertices    {}\n", info.vertices);
  fmt::print("triangles   {}\n", info.triangles);
  if (info.kind == "tetrahedral") fmt::print("tetrahedra  {}\n", info.tetrahedra);
  fmt::print("bbox min    {:.6g} {:.6g} {:.6g}\n", info.bbox_min.x(), info.bbox_min.y(),
             info.bbox_min.z());
  fmt::print("bbox max    {:.6g} {:.6g} {:.6g}\n", info.bbox_max.x(), info.bbox_max.y(),
             info.bbox_max.z());
  const Vec3 size = info.bbox_max - info.bbox_min;
  fmt::print("size        {:.6g} x {:.6g} x {:.6g}\n", size.x(), size.y(), size.z());
  fmt::print("closed      {} ({} boundary edges)\n", info.closed ? "yes" : "no", info.boundary_edges);
  fmt::print("manifold    {} ({} non-manifold edges)\n", info.manifold ? "yes" : "no",
             info.non_manifold_edges);
  if (info.kind == "tetrahedral")
    fmt::print("volume      {:.6g} (sum of tetrahedra)\n", info.volume);
  else if (info.closed)
    fmt::print("volume      {:.6g} (enclosed)\n", info.volume);
  else
    fmt::print("volume      - (surface is open)\n");
  fmt::print("edges       {}  min {:.6g}  mean {:.6g}  median {:.6g}  max {:.6g}\n",
             info.edges.count, info.edges.min, info.edges.mean, info.edges.median, info.edges.max);
  return 0;
}

}  // namespace

void add_info_command(CLI::App& app) {
  auto a = std::make_shared<InfoArgs>();
  CLI::App* info = app.add_subcommand("info", "Describe a mesh: counts, bounding box, closed/manifold, volume, edge lengths");
  info->add_option("file", a->file, "Mesh file: OBJ, STL, PLY, OFF, Gmsh .msh, TetGen .node/.ele, VTK")
      ->required()->check(CLI::ExistingFile);
  info->add_option("--scale", a->scale, "Multiply coordinates by this factor")->check(CLI::PositiveNumber);
  info->add_flag("--json", a->json, "Print the figures as one JSON object");
  add_output_flags(info, a->quiet, a->verbose);
  info->callback([a] { throw CLI::RuntimeError(info_command(*a)); });
}

}  // namespace palpate::cli
