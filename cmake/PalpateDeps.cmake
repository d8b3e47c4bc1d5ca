# Every dependency is a Debian package installed by scripts/install-deps; nothing is fetched here.
find_package(Threads REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(assimp REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(CLI11 REQUIRED)
find_package(fmt REQUIRED)
find_package(spdlog REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(TinyGLTF REQUIRED)  # libtinygltf-dev: the glTF export (src/io/export_gltf.cpp)

# The optional components (PALPATE_WITH_OSMESA, _GMSH, _CGAL): each is an interface target the
# layers link privately (palpate_osmesa, palpate_gmsh, palpate_cgal); one built without is empty:
# its package is not searched for and nothing of it is linked.
add_library(palpate_cgal INTERFACE)
if(PALPATE_WITH_CGAL)
  find_package(CGAL REQUIRED)  # isotropic remeshing for particles laid on a mesh (header-only)
  target_link_libraries(palpate_cgal INTERFACE CGAL::CGAL)
endif()

# Gmsh ships no CMake package on Debian: find its C++ API header and library.
add_library(palpate_gmsh INTERFACE)
if(PALPATE_WITH_GMSH)
  find_path(GMSH_INCLUDE_DIR gmsh.h REQUIRED)
  find_library(GMSH_LIBRARY NAMES gmsh REQUIRED)
  target_include_directories(palpate_gmsh SYSTEM INTERFACE ${GMSH_INCLUDE_DIR})
  target_link_libraries(palpate_gmsh INTERFACE ${GMSH_LIBRARY})
endif()

# METIS (libmetis-dev) ships no CMake package either: its nested-dissection ordering makes the
# sparse mass-spring predictor's factor much sparser on 3-D meshes than minimum degree.
find_path(METIS_INCLUDE_DIR metis.h REQUIRED)
find_library(METIS_LIBRARY NAMES metis REQUIRED)
add_library(palpate_metis INTERFACE)
target_include_directories(palpate_metis SYSTEM INTERFACE ${METIS_INCLUDE_DIR})
target_link_libraries(palpate_metis INTERFACE ${METIS_LIBRARY})

# Off-screen rendering (src/render): Mesa's OSMesa (software OpenGL); PNG files (src/io):
# stb_image_write. Neither has a CMake package on Debian.
add_library(palpate_osmesa INTERFACE)
if(PALPATE_WITH_OSMESA)
  find_path(OSMESA_INCLUDE_DIR GL/osmesa.h REQUIRED)
  find_library(OSMESA_LIBRARY NAMES OSMesa REQUIRED)
  target_include_directories(palpate_osmesa SYSTEM INTERFACE ${OSMESA_INCLUDE_DIR})
  target_link_libraries(palpate_osmesa INTERFACE ${OSMESA_LIBRARY})
endif()
find_path(STB_INCLUDE_DIR stb/stb_image_write.h REQUIRED)
add_library(palpate_stb INTERFACE)
target_include_directories(palpate_stb SYSTEM INTERFACE ${STB_INCLUDE_DIR})

if(PALPATE_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(PALPATE_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
