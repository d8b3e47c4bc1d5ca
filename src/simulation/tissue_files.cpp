// tissue_files.cpp — the file-backed TissueServices and builders (palpate/tissue_files.h).
#include <palpate/tissue_files.h>

#include <palpate/mesh_load.h>
#include <palpate/meshing.h>

#include "simulation/predictor_file.h"

namespace palpate {
namespace {

Result<SurfaceMesh> load_surface_file(const std::filesystem::path& file, double scale, const SurfaceRequirements& need) {
  return load_surface(file, scale, need);
}
Result<TetMesh> load_tet_file(const std::filesystem::path& file, double scale) { return load_tet(file, scale); }
Result<TetMesh> fill_surface(const SurfaceMesh& surface, const FillOptions& options) {
  return tetrahedralize(surface, options);
}
Result<std::string> read_predictor_file(const std::filesystem::path& file) {
  return read_checked_file(file, predictor_file_format());
}
Status write_predictor_file(const std::filesystem::path& file, std::string_view payload) {
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

const TissueServices& file_tissue_services() {
  static const TissueServices services{
      .load_surface = &load_surface_file,
      .load_tet = &load_tet_file,
      .fill = &fill_surface,
      .remesh = &remesh_isotropic,
      .read_predictor = &read_predictor_file,
      .write_predictor = &write_predictor_file,
  };
  return services;
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
  return write_checked_file(file, predictor_file_format(), *payload);
}

Result<SpringPredictor> load_predictor(const std::filesystem::path& file, const SpringNetwork& network,
                                       const SpringModelOptions& options) {
  Result<std::string> payload = read_checked_file(file, predictor_file_format());
  if (!payload) return payload.error();
  return decode_predictor(*payload, network, options, file.string() + ": ");
}

}  // namespace palpate
