// palpate/tissue_files.h — tissues built from files (the simulation layer): the TissueServices
// that read meshes (io), fill and remesh them (meshing) and keep predictors in checked files, and
// the file-backed forms of the tissue layer's builders that take them. What `palpate run`, `view`,
// `precompute`, the benchmarks and the tests use; an embedding program that makes its own meshes
// can build models with the tissue layer alone (examples/tissue_only).
#pragma once

#include <palpate/charged.h>
#include <palpate/checked_file.h>
#include <palpate/core.h>
#include <palpate/spring.h>
#include <palpate/tissue.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace palpate {

// The predictor file: "PALPPRED", version 1, around encode_predictor's payload.
const CheckedFileFormat& predictor_file_format();

// Where predictors a scene does not name are kept by default: default_cache_dir()/predictors
// ($XDG_CACHE_HOME/palpate/predictors, else ~/.cache/palpate/predictors; empty, none kept, when
// neither variable is set).
std::filesystem::path default_predictor_cache();

// Every service from files and meshers: load_surface, load_tet, tetrahedralize, remesh_isotropic,
// and predictor files (read_checked_file / write_checked_file in predictor_file_format(); a write
// first removes the temporary files a killed writer left beside it), predictors the scene does not
// name kept in `predictor_cache`.
TissueServices file_tissue_services(std::filesystem::path predictor_cache = default_predictor_cache());

// Remove the least recently used predictors (by their files' time: a load touches it) from `cache`
// until its *.predictor files take at most `max_bytes`; the newest always stays. `palpate run` and
// `view` keep their cache under PALPATE_CACHE_BYTES (default 4 GB) this way after each save.
// Returns how many were removed.
size_t prune_predictor_cache(const std::filesystem::path& cache, std::uintmax_t max_bytes);

// make_tissue with file_tissue_services().
Result<std::unique_ptr<Tissue>> make_tissue(const SceneDef& scene, int index);

// build_charged_on_mesh with CGAL's remeshing.
Result<ChargedModel> build_charged_on_mesh(const SurfaceMesh& surface, const ChargedMaterialDef& material,
                                           const std::string& where = "mesh");

// spring_setup and spring_network_from_file reading (and filling) their meshes from files.
Result<SpringTissueSetup> spring_setup(const SceneDef& scene, int index);
Result<SpringNetwork> spring_network_from_file(const MeshRef& mesh, const SpringNetworkOptions& options);

// build_spring_model's predictor policy over a predictor file.
Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       const std::filesystem::path& file, PredictorPolicy policy,
                                       std::string* note = nullptr, const Progress& progress = {});

// Write the model's predictor with every parameter it depends on, atomically (temp + fsync + rename).
Status save_predictor(const std::filesystem::path& file, const SpringModel& model);
// Read a predictor made for exactly this network and these options; a missing, truncated,
// corrupted, other-mesh or other-parameter file is refused with a message saying which.
Result<SpringPredictor> load_predictor(const std::filesystem::path& file, const SpringNetwork& network,
                                       const SpringModelOptions& options);

}  // namespace palpate
