# PalpateInstall.cmake — what `cmake --install` puts where (included from the top-level
# CMakeLists.txt when PALPATE_INSTALL is on): every layer's public headers (into one
# include/palpate/), its library, the CMake package (palpate::palpate, or one layer: palpate::core,
# palpate::tissue, ...; each layer and each optional component built in is also a component of
# find_package(palpate COMPONENTS ...)), one pkg-config file per layer, and the scene schema.
# The same package is exported into the build tree (<build>/palpateConfig.cmake), so a project can
# use a palpate that was built and not installed: -Dpalpate_DIR=<build>.
include(CMakePackageConfigHelpers)

foreach(layer IN LISTS PALPATE_LAYERS)
  install(DIRECTORY include/${layer}/palpate DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  list(APPEND PALPATE_LAYER_TARGETS palpate_${layer})
endforeach()

# A static layer's private libraries are linked by its user: the small interface targets of
# cmake/PalpateDeps.cmake and cmake/PalpateWarnings.cmake that name them go into the package too
# (under palpate::detail_*; their compile options and include paths are never the user's: a
# private link item reaches the user as $<LINK_ONLY:...>), and the package config finds the
# libraries' own packages (fmt, assimp, yaml-cpp, nlohmann_json, TinyGLTF, CGAL).
set(PALPATE_DETAIL_TARGETS)
if(NOT BUILD_SHARED_LIBS)
  foreach(d warnings metis gmsh cgal osmesa stb)
    set_target_properties(palpate_${d} PROPERTIES EXPORT_NAME detail_${d})
    list(APPEND PALPATE_DETAIL_TARGETS palpate_${d})
  endforeach()
endif()

install(TARGETS palpate ${PALPATE_LAYER_TARGETS} ${PALPATE_DETAIL_TARGETS} EXPORT palpateTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT palpateTargets NAMESPACE palpate:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/palpate)
export(EXPORT palpateTargets NAMESPACE palpate:: FILE ${PROJECT_BINARY_DIR}/palpateTargets.cmake)

# What the config file is told: the layers, the optional components built in, shared or static.
set(PALPATE_COMPONENTS ${PALPATE_LAYERS})
foreach(c OSMESA GMSH CGAL)
  string(TOLOWER ${c} lc)
  if(PALPATE_WITH_${c})
    list(APPEND PALPATE_COMPONENTS ${lc})
  endif()
endforeach()
set(PALPATE_CONFIG_SHARED ${BUILD_SHARED_LIBS})
set(PALPATE_CONFIG_WITH_CGAL ${PALPATE_WITH_CGAL})
configure_package_config_file(cmake/palpateConfig.cmake.in
  ${PROJECT_BINARY_DIR}/palpateConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/palpate)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/palpateConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/palpateConfig.cmake
              ${PROJECT_BINARY_DIR}/palpateConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/palpate)

# The scene files' JSON Schema (data/schema/scene.schema.json; `palpate schema` prints the same).
install(FILES data/schema/scene.schema.json DESTINATION ${CMAKE_INSTALL_DATADIR}/palpate)

# --- pkg-config: palpate-<layer>.pc for each layer (Requires: the layers below it), palpate.pc for
# the whole library. Cflags carry no -std: a user compiles with -std=c++20 or later (docs).
# A static build lists each layer's private libraries for `pkg-config --static`.
set(_pc_requires_private_io "assimp yaml-cpp tinygltf")
set(_pc_libs_private_tissue "-lmetis")
set(_pc_libs_private_haptics "-l${CMAKE_DL_LIBS}")
if(PALPATE_WITH_GMSH)
  set(_pc_libs_private_io "-lgmsh")
  set(_pc_libs_private_meshing "-lgmsh")
endif()
if(PALPATE_WITH_CGAL)
  set(_pc_requires_private_meshing "gmp mpfr")
endif()
if(PALPATE_WITH_OSMESA)
  set(_pc_requires_private_render "osmesa")
endif()
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  set(_pc_libdir "${CMAKE_INSTALL_LIBDIR}")
else()
  set(_pc_libdir "\${prefix}/${CMAKE_INSTALL_LIBDIR}")
endif()
if(IS_ABSOLUTE "${CMAKE_INSTALL_INCLUDEDIR}")
  set(_pc_includedir "${CMAKE_INSTALL_INCLUDEDIR}")
else()
  set(_pc_includedir "\${prefix}/${CMAKE_INSTALL_INCLUDEDIR}")
endif()
set(PC_PREFIX "@PC_PREFIX@")  # kept for the install step below
# The prefix is the one `cmake --install --prefix` is given, not the configured one: the file is
# written at install time.
foreach(layer IN LISTS PALPATE_LAYERS)
  set(req "eigen3")
  foreach(d IN LISTS PALPATE_LAYER_DEPENDS_${layer})
    string(APPEND req " palpate-${d}")
  endforeach()
  set(priv "")
  set(libs_priv "")
  if(NOT BUILD_SHARED_LIBS)
    set(priv "fmt ${_pc_requires_private_${layer}}")
    set(libs_priv "${_pc_libs_private_${layer}} -pthread")
  endif()
  set(PC_NAME "palpate-${layer}")
  set(PC_DESCRIPTION "palpate's ${layer} layer (real-time soft tissue with force feedback)")
  set(PC_REQUIRES "${req}")
  set(PC_REQUIRES_PRIVATE "${priv}")
  set(PC_LIBS "-L\${libdir} -lpalpate_${layer}")
  set(PC_LIBS_PRIVATE "${libs_priv}")
  configure_file(cmake/palpate.pc.in ${PROJECT_BINARY_DIR}/pkgconfig/palpate-${layer}.pc.in @ONLY)
endforeach()
set(PC_NAME "palpate")
set(PC_DESCRIPTION "${PROJECT_DESCRIPTION}: every layer of palpate")
set(PC_REQUIRES "palpate-simulation")
set(PC_REQUIRES_PRIVATE "")
set(PC_LIBS "")
set(PC_LIBS_PRIVATE "")
configure_file(cmake/palpate.pc.in ${PROJECT_BINARY_DIR}/pkgconfig/palpate.pc.in @ONLY)
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  set(_pc_dest "${CMAKE_INSTALL_LIBDIR}/pkgconfig")
else()
  set(_pc_dest "\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}/pkgconfig")
endif()
foreach(pc IN LISTS PALPATE_LAYERS ITEMS "")
  if(pc STREQUAL "")
    set(pc_file palpate.pc)
  else()
    set(pc_file palpate-${pc}.pc)
  endif()
  install(CODE "
    file(READ \"${PROJECT_BINARY_DIR}/pkgconfig/${pc_file}.in\" _pc)
    string(REPLACE \"@PC_PREFIX@\" \"\${CMAKE_INSTALL_PREFIX}\" _pc \"\${_pc}\")
    file(WRITE \"\$ENV{DESTDIR}${_pc_dest}/${pc_file}\" \"\${_pc}\")
    message(STATUS \"Installing: \$ENV{DESTDIR}${_pc_dest}/${pc_file}\")")
endforeach()
