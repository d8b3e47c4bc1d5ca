// fuzz_predictor.cpp — load_predictor on the input, against the networks of the unit cube
// (tests/data/meshes/cube_1based.node) for each precomputing solver (desbrun: the dense inverse;
// sparse: the LDLᵀ factor). The checksum would stop nearly every mutation at the header, so each
// input is tried twice: as it is, and with its header's checksum recomputed over its payload — a
// file edited by someone who recomputed it, whose numbers must be checked for themselves.
// With FUZZ_PREDICTOR_SEEDS=<dir> set, it first writes the two real predictor files there (the
// seed corpus) .
#include <palpate/spring.h>
#include <palpate/mesh_load.h>
#include <palpate/tissue_files.h>

#include "fuzz_common.h"
#include "simulation/predictor_file.h"

#include <cstring>
#include <vector>

namespace {

struct Config {
  palpate::SpringNetwork network;
  palpate::SpringModelOptions options;
};

std::vector<Config>& configs() {
  static std::vector<Config> c;
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  using namespace palpate;
  Result<TetMesh> mesh = load_tet(PALPATE_TEST_DATA_DIR "/meshes/cube_1based.node");
  if (!mesh) {
    std::fprintf(stderr, "fuzz_predictor: %s\n", mesh.error().message.c_str());
    std::abort();
  }
  SpringNetworkOptions net_options;
  net_options.anchors = {0, 1};
  for (SpringSolver solver : {SpringSolver::desbrun, SpringSolver::sparse}) {
    Result<SpringNetwork> net = make_spring_network(*mesh, net_options, "cube");
    if (!net) std::abort();
    SpringModelOptions options;
    options.solver = solver;
    configs().push_back({*net, options});
    if (const char* dir = std::getenv("FUZZ_PREDICTOR_SEEDS")) {
      Result<SpringModel> model = build_spring_model(*net, options);
      if (!model) std::abort();
      const std::string name = solver == SpringSolver::desbrun ? "/cube-desbrun.predictor" : "/cube-sparse.predictor";
      if (Status s = save_predictor(std::string(dir) + name, *model); !s) std::abort();
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
  namespace pf = palpate::predictor_file;
  std::string bytes(fuzz::bytes(data, size));
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      if (bytes.size() < pf::kHeaderSize) break;
      const std::uint64_t payload = bytes.size() - pf::kHeaderSize;
      const std::uint64_t sum =
          pf::checksum(reinterpret_cast<const unsigned char*>(bytes.data()) + pf::kHeaderSize, payload);
      std::memcpy(bytes.data() + 16, &payload, 8);
      std::memcpy(bytes.data() + 24, &sum, 8);
    }
    const auto file = fuzz::write_file("input.predictor", bytes);
    for (const Config& c : configs())
      fuzz::no_throw([&] {
        Result<SpringPredictor> p = load_predictor(file, c.network, c.options);
        fuzz::check(p, file.string());
        if (p) {  // a loaded predictor drives a model that steps without blowing up at rest
          Result<SpringModel> model = build_spring_model(c.network, c.options, std::move(*p));
          if (!model) return;
          SpringState state = make_state(*model);
          for (int i = 0; i < 10; ++i)
            if (!step(*model, state, nullptr)) {
              std::fprintf(stderr, "fuzz_predictor: a loaded predictor blew the tissue up at rest\n");
              std::abort();
            }
        }
      });
  }
  return 0;
}
