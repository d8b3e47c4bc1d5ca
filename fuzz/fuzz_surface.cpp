// fuzz_surface.cpp — load_surface on the input saved as input<FUZZ_EXTENSION> (one target per
// documented format: .obj, .ply, .stl, .off; assimp picks the reader, palpate's checks run first).
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
  const auto file = fuzz::save_input("input" FUZZ_EXTENSION, data, size);
  fuzz::no_throw([&] {
    Result<SurfaceMesh> m = load_surface(file);
    fuzz::check(m, file.string());
    if (m) {  // what load_surface returns is validated: indices in range (describe reads them)
      const MeshInfo info = describe(*m);
      if (info.vertices != static_cast<size_t>(m->V.rows())) std::abort();
    }
  });
  return 0;
}
