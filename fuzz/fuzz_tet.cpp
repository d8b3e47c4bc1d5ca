// fuzz_tet.cpp — load_tet on the input saved as input<FUZZ_EXTENSION>: .msh (Gmsh v1/v2/v4, ASCII
// and binary, through Gmsh after palpate's own checks) or .vtk (legacy ASCII, palpate's reader).
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
  const auto file = fuzz::save_input("input" FUZZ_EXTENSION, data, size);
  fuzz::no_throw([&] {
    Result<TetMesh> m = load_tet(file);
    fuzz::check(m, file.string());
    if (m && !validate(*m, "fuzz")) std::abort();  // load_tet's result is valid
  });
  return 0;
}
