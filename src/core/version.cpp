// version.cpp — the library's version string, set by CMake from project(), and its components.
#include <palpate/core.h>

namespace palpate {
const char* version() { return PALPATE_VERSION_STRING; }

std::string components() {
  auto yes = [](bool b) { return b ? "yes" : "no"; };
  return std::string("OSMesa ") + yes(PALPATE_HAS_OSMESA) + ", Gmsh " + yes(PALPATE_HAS_GMSH) + ", CGAL " +
         yes(PALPATE_HAS_CGAL);
}
}  // namespace palpate
