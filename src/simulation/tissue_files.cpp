// tissue_files.cpp — the file-backed TissueServices and builders (palpate/tissue_files.h).
#include <palpate/tissue_files.h>

#include <palpate/mesh_load.h>
#include <palpate/meshing.h>

#include "simulation/predictor_file.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace palpate {
namespace {

Result<SurfaceMesh> load_surface_file(const std::filesystem::path& file, double scale, const SurfaceRequirements& need) {
  return load_surface(file, scale, need);
}
Result<TetMesh> load_tet_file(const std::filesystem::path& file, double scale) { return load_tet(file, scale); }
Result<TetMesh> fill_surface(const SurfaceMesh& surface, const FillOptions& options) {
  return tetrahedralize(surface, options);
}
Result<StoredPredictor> read_predictor_file(const std::filesystem::path& file) {
  std::error_code ec;
  StoredPredictor stored;
  if (!std::filesystem::exists(file, ec)) {
    stored.why = file.string() + ": no predictor file";
    return stored;
  }
  if (Status s = check_regular_file(file, predictor_file_format().expected); !s) return s.error();
  Result<std::string> payload = read_checked_file(file, predictor_file_format());
  if (!payload) {
    stored.why = payload.error().message;
    return stored;
  }
  stored.present = true;
  stored.payload = std::move(*payload);
  // Used now: the cache keeps what was used last (prune_predictor_cache removes the oldest first).
  std::filesystem::last_write_time(file, std::filesystem::file_time_type::clock::now(), ec);
  return stored;
}
// The cache's size limit: PALPATE_CACHE_BYTES, else 4 GB.
std::uintmax_t cache_limit() {
  if (const char* v = std::getenv("PALPATE_CACHE_BYTES"); v && *v) {
    char* end = nullptr;
    const double bytes = std::strtod(v, &end);
    if (end && *end == '\0' && bytes >= 0) return static_cast<std::uintmax_t>(bytes);
  }
  return std::uintmax_t{4} << 30;
}

Status write_predictor_file(const std::filesystem::path& file, std::string_view payload) {
  (void)remove_stale_temporaries(file);  // a run killed while saving this predictor left one
  return write_checked_file(file, predictor_file_format(), payload);
}

}  // namespace

const CheckedFileFormat& predictor_file_format() {
  static const CheckedFileFormat format{
      .magic = {'P', 'A', 'L', 'P', 'P', 'R', 'E', 'D'},
      .version = predictor_file::kVersion,
      .name = "predictor file",
      .expected = "a palpate predictor file (material.predictor)",
  };
  return format;
}

std::filesystem::path default_predictor_cache() {
  const std::filesystem::path dir = default_cache_dir();
  return dir.empty() ? dir : dir / "predictors";
}

size_t prune_predictor_cache(const std::filesystem::path& cache, std::uintmax_t max_bytes) {
  namespace fs = std::filesystem;
  struct Entry {
    fs::file_time_type used;
    std::uintmax_t bytes;
    fs::path path;
  };
  std::vector<Entry> entries;
  std::uintmax_t total = 0;
  std::error_code ec;
  for (fs::directory_iterator it(cache, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    if (it->path().extension() != ".predictor" || !it->is_regular_file(ec)) continue;
    Entry e{it->last_write_time(ec), it->file_size(ec), it->path()};
    if (ec) continue;
    total += e.bytes;
    entries.push_back(std::move(e));
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.used < b.used; });
  size_t removed = 0;
  for (size_t i = 0; i + 1 < entries.size() && total > max_bytes; ++i) {  // the newest always stays
    std::error_code gone;
    if (fs::remove(entries[i].path, gone)) {
      total -= entries[i].bytes;
      ++removed;
    }
  }
  return removed;
}

TissueServices file_tissue_services(std::filesystem::path predictor_cache) {
  TissueServices s{
      .load_surface = &load_surface_file,
      .load_tet = &load_tet_file,
      .fill = &fill_surface,
      .remesh = &remesh_isotropic,
      .read_predictor = &read_predictor_file,
      .write_predictor = &write_predictor_file,
      .predictor_cache = predictor_cache,
  };
  // A predictor saved into the cache may push it past its limit: the least recently used go.
  s.write_predictor = [cache = std::move(predictor_cache)](const std::filesystem::path& file, std::string_view payload) {
    Status st = write_predictor_file(file, payload);
    if (st && !cache.empty() && file.parent_path() == cache) (void)prune_predictor_cache(cache, cache_limit());
    return st;
  };
  return s;
}

Result<std::unique_ptr<Tissue>> make_tissue(const SceneDef& scene, int index) {
  return make_tissue(scene, index, file_tissue_services());
}

Result<ChargedModel> build_charged_on_mesh(const SurfaceMesh& surface, const ChargedMaterialDef& material,
                                           const std::string& where) {
  return build_charged_on_mesh(surface, material, where, file_tissue_services());
}

Result<SpringTissueSetup> spring_setup(const SceneDef& scene, int index) {
  return spring_setup(scene, index, file_tissue_services());
}

Result<SpringNetwork> spring_network_from_file(const MeshRef& mesh, const SpringNetworkOptions& options) {
  return spring_network_from_file(mesh, options, file_tissue_services());
}

Result<SpringModel> build_spring_model(SpringNetwork network, const SpringModelOptions& options,
                                       const std::filesystem::path& file, PredictorPolicy policy, std::string* note,
                                       const Progress& progress) {
  return build_spring_model(std::move(network), options, file, policy, file_tissue_services(), note, progress);
}

Status save_predictor(const std::filesystem::path& file, const SpringModel& model) {
  Result<std::string> payload = encode_predictor(model, file.string());
  if (!payload) return payload.error();
  return write_predictor_file(file, *payload);
}

Result<SpringPredictor> load_predictor(const std::filesystem::path& file, const SpringNetwork& network,
                                       const SpringModelOptions& options) {
  Result<std::string> payload = read_checked_file(file, predictor_file_format());
  if (!payload) return payload.error();
  return decode_predictor(*payload, network, options, file.string() + ": ");
}

}  // namespace palpate
