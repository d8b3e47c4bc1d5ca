// fuzz_tetgen.cpp — load_tet on a TetGen pair: the input is split at its first line "%%ele%%"
// into input.node (before) and input.ele (after); without the line, all of it is the .node and the
// .ele is empty.
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  using namespace palpate;
  const std::string_view in = fuzz::bytes(data, size);
  constexpr std::string_view kSeparator = "\n%%ele%%\n";
  const size_t at = in.find(kSeparator);
  const std::string_view node = at == std::string_view::npos ? in : in.substr(0, at + 1);
  const std::string_view ele = at == std::string_view::npos ? std::string_view{} : in.substr(at + kSeparator.size());
  const auto node_file = fuzz::write_file("input.node", node);
  fuzz::write_file("input.ele", ele);
  fuzz::no_throw([&] {
    Result<TetMesh> m = load_tet(node_file);
    // An error names the .node or the .ele: both share the stem.
    fuzz::check(m, (fuzz::scratch_dir() / "input.").string());
    if (m && !validate(*m, "fuzz")) std::abort();
  });
  return 0;
}
