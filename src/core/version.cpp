// version.cpp — the library's version string, set by CMake from project().
#include <palpate/core.h>

namespace palpate {
const char* version() { return PALPATE_VERSION_STRING; }
}  // namespace palpate
