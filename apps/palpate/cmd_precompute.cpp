// cmd_precompute.cpp — `palpate precompute SCENE_OR_MESH [-o FILE] [--dt S] ...`: build the
// mass-spring predictor (the expensive phase) and write it to a file, with a progress bar on a terminal.
#include <palpate/palpate.h>
#include <palpate/spring.h>
#include <palpate/tissue_files.h>

#include "commands.h"

#include <fmt/core.h>

#include <chrono>
#include <cstdio>
#include <memory>

namespace palpate::cli {

namespace {

struct PrecomputeArgs {
  std::string input;
  std::string out;
  std::string cache;
  std::string tissue;
  double dt = 0.001;
  std::string solver = "sparse";
  std::string topology = "tet_edges";
  double stiffness = 100.0, youngs_modulus = 0.0, spring_damping = 0.1, point_damping = 0.5;
  double mass = 0.1, density = 0.0, scale = 1.0;
  std::vector<int> anchors;
  bool quiet = false;
  bool verbose = false;
};

bool is_scene(const std::filesystem::path& p) {
  const auto e = p.extension().string();
  return e == ".yaml" || e == ".yml";
}

Progress bar(bool show, const std::string& label) {
  if (!show) return {};
  return [label](double f) {
    const int width = 40, filled = static_cast<int>(f * width);
    fmt::print(stderr, "\r  {} [{:<{}}] {:3.0f}%", label, std::string(static_cast<size_t>(filled), '#'), width, f * 100);
    if (f >= 1.0) fmt::print(stderr, "\n");
  };
}

int write_one(const std::string& label, SpringNetwork network, const SpringModelOptions& options,
              const std::filesystem::path& file, const PrecomputeArgs& a) {
  const size_t n = network.size(), s = network.springs.size();
  const auto t0 = std::chrono::steady_clock::now();
  auto model = build_spring_model(std::move(network), options, bar(!a.quiet && stderr_is_terminal(), label));
  if (!model) {
    fmt::print(stderr, "palpate precompute: {}: {}\n", label, model.error().message);
    return 1;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (Status st = save_predictor(file, *model); !st) {
    fmt::print(stderr, "palpate precompute: {}\n", st.error().message);
    return 1;
  }
  if (!a.quiet) {
    const auto& p = model->predictor;
    fmt::print("{}: {} vertices, {} springs, {} anchored, dt {} s, solver {}\n", label, n, s,
               model->network.anchors.size(), options.dt, options.solver == SpringSolver::desbrun ? "desbrun" : "sparse");
    if (options.solver == SpringSolver::desbrun) fmt::print("  dense inverse {} x {}\n", n, n);
    else fmt::print("  sparse LDLT factor, {} non-zeros below the diagonal\n", p.value.size());
    fmt::print("  built in {:.3f} s, wrote {} ({:.1f} MiB)\n", seconds, file.string(),
               static_cast<double>(std::filesystem::file_size(file)) / (1024.0 * 1024.0));
  }
  return 0;
}

int precompute_command(const PrecomputeArgs& a) {
  const std::filesystem::path input = a.input;
  if (is_scene(input)) {
    auto scene = load_scene(input);
    if (!scene) {
      fmt::print(stderr, "palpate precompute: {}\n", scene.error().message);
      return kExitFailed;
    }
    if (a.verbose) print_scene_inputs(*scene, a.cache);
    int done = 0, rc = 0;
    for (size_t i = 0; i < scene->tissues.size(); ++i) {
      const TissueDef& t = scene->tissues[i];
      if (t.model != "mass_spring" || (!a.tissue.empty() && t.name != a.tissue)) continue;
      auto setup = spring_setup(*scene, static_cast<int>(i),
                                file_tissue_services(a.cache.empty() ? default_predictor_cache() : std::filesystem::path(a.cache)));
      if (!setup) {
        fmt::print(stderr, "palpate precompute: {}\n", setup.error().message);
        return kExitFailed;
      }
      if (setup->options.solver == SpringSolver::exact) {
        fmt::print(stderr, "palpate precompute: tissue '{}' uses the exact solver, which has no predictor\n", t.name);
        rc = 1;
        continue;
      }
      const std::filesystem::path file = a.out.empty() ? setup->predictor : std::filesystem::path(a.out);
      if (!a.out.empty() && done > 0) {
        fmt::print(stderr, "palpate precompute: -o names one file but the scene has several mass_spring tissues; "
                           "use --tissue NAME\n");
        return kExitUsage;
      }
      rc |= write_one(t.name, std::move(setup->network), setup->options, file, a);
      ++done;
    }
    if (done == 0) {
      fmt::print(stderr, "palpate precompute: {}: no mass_spring tissue{}\n", input.string(),
                 a.tissue.empty() ? "" : " named '" + a.tissue + "'");
      return kExitFailed;
    }
    return rc;
  }
  SpringMaterialDef m;
  m.topology = a.topology;
  m.stiffness = a.stiffness;
  m.youngs_modulus = a.youngs_modulus;
  m.spring_damping = a.spring_damping;
  m.mass = a.mass;
  m.density = a.density;
  auto net_opt = network_options(m, a.anchors, input.string());
  if (!net_opt) {
    fmt::print(stderr, "palpate precompute: {}\n", net_opt.error().message);
    return kExitUsage;
  }
  auto solver = parse_solver(a.solver, "--solver");
  if (!solver || *solver == SpringSolver::exact) {
    fmt::print(stderr, "palpate precompute: --solver must be desbrun or sparse\n");
    return kExitUsage;
  }
  if (a.verbose) fmt::print("loaded     mesh {} (scale {})\n", std::filesystem::absolute(input).string(), a.scale);
  MeshRef ref;
  ref.file = input;
  ref.scale = a.scale;
  auto net = spring_network_from_file(ref, *net_opt);
  if (!net) {
    fmt::print(stderr, "palpate precompute: {}\n", net.error().message);
    return kExitFailed;
  }
  SpringModelOptions o;
  o.dt = a.dt;
  o.solver = *solver;
  o.point_damping = a.point_damping;
  std::filesystem::path file = a.out;
  if (file.empty()) file = std::filesystem::path(input).replace_extension(".predictor");
  return write_one(input.filename().string(), std::move(*net), o, file, a);
}

}  // namespace

void add_precompute_command(CLI::App& app) {
  auto a = std::make_shared<PrecomputeArgs>();
  CLI::App* c = app.add_subcommand(
      "precompute", "Build a mass-spring organ's implicit predictor and write it to a file (loaded by `run`)");
  c->add_option("input", a->input, "A scene (.yaml: every mass_spring tissue) or a mesh file")
      ->required()->check(CLI::ExistingFile);
  c->add_option("--out,-o", a->out, "Predictor file (default: the tissue's `predictor`, else the cache's file for it; MESH.predictor)");
  c->add_option("--cache", a->cache, "Folder for the predictors a scene does not name (default: $XDG_CACHE_HOME/palpate/predictors or ~/.cache/palpate/predictors)");
  c->add_option("--tissue", a->tissue, "Scene: only the mass_spring tissue with this name");
  c->add_option("--dt", a->dt, "Mesh: time step the predictor is built for, s")->check(CLI::Range(1e-6, 0.5));
  c->add_option("--solver", a->solver, "Mesh: desbrun (dense inverse) or sparse (LDLT)")->check(CLI::IsMember({"desbrun", "sparse"}));
  c->add_option("--topology", a->topology, "Mesh: all_pairs, edges or tet_edges")
      ->check(CLI::IsMember({"all_pairs", "edges", "tet_edges"}));
  c->add_option("--stiffness", a->stiffness, "Mesh: N/m per spring")->check(CLI::Range(0.0, 1e9));
  c->add_option("--youngs-modulus", a->youngs_modulus, "Mesh: Pa; > 0 derives spring stiffness")->check(CLI::Range(0.0, 1e10));
  c->add_option("--spring-damping", a->spring_damping, "Mesh: N·s/m per spring")->check(CLI::Range(0.0, 1e6));
  c->add_option("--point-damping", a->point_damping, "Mesh: N·s/m on each mass")->check(CLI::Range(0.0, 1e6));
  c->add_option("--mass", a->mass, "Mesh: total mass, kg")->check(CLI::Range(1e-9, 1e6));
  c->add_option("--density", a->density, "Mesh: kg/m³; > 0 lumps masses from volume")->check(CLI::Range(0.0, 1e5));
  c->add_option("--scale", a->scale, "Mesh: multiplies coordinates (to metres)")->check(CLI::Range(1e-9, 1e9));
  c->add_option("--anchors", a->anchors, "Mesh: fixed vertex indices")->delimiter(',');
  add_output_flags(c, a->quiet, a->verbose);
  c->callback([a] { throw CLI::RuntimeError(precompute_command(*a)); });
}

}  // namespace palpate::cli
