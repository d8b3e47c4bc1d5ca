// components.h — internal: the error of a function whose optional component palpate was built
// without (the *_none.cpp sources; src/CMakeLists.txt), naming the CMake option that builds it in.
#pragma once

#include <palpate/core.h>

#include <string>
#include <string_view>

namespace palpate {

// "liver.msh: palpate was built without Gmsh (cmake -DPALPATE_WITH_GMSH=ON): cannot read a Gmsh
// .msh mesh". `where` first, as every error (the file, or the function); `component` as its
// project spells it, `option` the part after PALPATE_WITH_.
inline Error built_without(std::string_view where, std::string_view component, std::string_view option,
                           std::string_view what) {
  return Error{std::string(where) + ": palpate was built without " + std::string(component) +
               " (cmake -DPALPATE_WITH_" + std::string(option) + "=ON): " + std::string(what)};
}

}  // namespace palpate
