# palpate as a package other projects use (issue 36, part 8), one MODE per test:
#   pkgconfig  — install into a scratch prefix, then build examples/tissue_only with nothing but
#                `g++ -std=c++20 $(pkg-config --cflags --libs palpate-tissue)` and run it;
#   component  — install, then find_package(palpate COMPONENTS ${WANTED}) must succeed when
#                EXPECT_FOUND is true, and otherwise fail with a message naming the missing one;
#   subproject — tests/package/subproject: palpate added with add_subdirectory and built static;
#                its program must run and load no palpate library.
# Inputs: MODE, PALPATE_BINARY_DIR, PALPATE_SOURCE_DIR, WORK_DIR, CXX (the compiler), WANTED,
# EXPECT_FOUND, EXPECT_TEXT (WANTED: components separated by commas).
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(run_checked what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc)
    message(FATAL_ERROR "${what} failed (exit ${rc}):\n${out}${err}")
  endif()
  set(last_out "${out}${err}" PARENT_SCOPE)
endfunction()

function(install_palpate)
  run_checked("installing palpate" ${CMAKE_COMMAND} --install ${PALPATE_BINARY_DIR} --prefix ${WORK_DIR}/prefix)
endfunction()

if(MODE STREQUAL "pkgconfig")
  install_palpate()
  file(GLOB_RECURSE pcs ${WORK_DIR}/prefix/*/palpate-tissue.pc)
  list(LENGTH pcs n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "expected one installed palpate-tissue.pc, found: ${pcs}")
  endif()
  get_filename_component(pcdir ${pcs} DIRECTORY)
  set(ENV{PKG_CONFIG_PATH} ${pcdir})
  # Every layer's file and the whole library's must resolve (their Requires name each other).
  file(GLOB all_pcs RELATIVE ${pcdir} ${pcdir}/palpate*.pc)
  foreach(pc IN LISTS all_pcs)
    string(REGEX REPLACE "\\.pc$" "" name ${pc})
    run_checked("pkg-config --libs ${name}" pkg-config --cflags --libs ${name})
    if(NOT last_out MATCHES "-I${WORK_DIR}/prefix/include" OR NOT last_out MATCHES "-lpalpate_core")
      message(FATAL_ERROR "pkg-config ${name}: expected the prefix's include folder and -lpalpate_core, got: ${last_out}")
    endif()
  endforeach()
  run_checked("pkg-config palpate-tissue" pkg-config --cflags --libs palpate-tissue)
  string(STRIP "${last_out}" flags)
  separate_arguments(flags UNIX_COMMAND "${flags}")
  foreach(f IN LISTS flags)
    if(f MATCHES "palpate_(io|meshing|haptics|render|simulation)")
      message(FATAL_ERROR "pkg-config palpate-tissue links a layer above it: ${f}")
    endif()
  endforeach()
  run_checked("compiling examples/tissue_only with pkg-config's flags"
              ${CXX} -std=c++20 ${PALPATE_SOURCE_DIR}/examples/tissue_only/main.cpp ${flags}
              -Wl,-rpath,${WORK_DIR}/prefix/lib -o ${WORK_DIR}/tissue_only)
  run_checked("running the program" ${WORK_DIR}/tissue_only)
  if(NOT last_out MATCHES "charged patch: [0-9.]+ N up.*mass-spring sheet: [0-9.]+ N up")
    message(FATAL_ERROR "the program built with pkg-config did not print its forces:\n${last_out}")
  endif()
  message("${last_out}")
elseif(MODE STREQUAL "component")
  string(REPLACE "," ";" WANTED "${WANTED}")  # given with commas (tests/CMakeLists.txt)
  install_palpate()
  execute_process(COMMAND ${CMAKE_COMMAND} -S ${PALPATE_SOURCE_DIR}/tests/package/component -B ${WORK_DIR}/build
                          -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix "-DWANTED=${WANTED}"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}${err}")
  if(EXPECT_FOUND AND rc)
    message(FATAL_ERROR "find_package(palpate COMPONENTS ${WANTED}) failed")
  elseif(NOT EXPECT_FOUND AND NOT rc)
    message(FATAL_ERROR "find_package(palpate COMPONENTS ${WANTED}) succeeded; expected it to fail")
  endif()
  if(NOT "${out}${err}" MATCHES "${EXPECT_TEXT}")
    message(FATAL_ERROR "expected the configure output to match '${EXPECT_TEXT}'")
  endif()
elseif(MODE STREQUAL "subproject")
  # No build type: palpate must not choose one for the project that includes it (and -O0 builds
  # the two layers quickly).
  run_checked("configuring a project that adds palpate with add_subdirectory"
              ${CMAKE_COMMAND} -S ${PALPATE_SOURCE_DIR}/tests/package/subproject -B ${WORK_DIR}/build
              -DPALPATE_SOURCE_DIR=${PALPATE_SOURCE_DIR} -DCMAKE_CXX_COMPILER=${CXX})
  run_checked("building it" ${CMAKE_COMMAND} --build ${WORK_DIR}/build -j2 --target tissue_only)
  run_checked("running its program" ${WORK_DIR}/build/tissue_only)
  if(NOT last_out MATCHES "charged patch: [0-9.]+ N up.*mass-spring sheet: [0-9.]+ N up")
    message(FATAL_ERROR "the program did not print its forces:\n${last_out}")
  endif()
  run_checked("ldd" ldd ${WORK_DIR}/build/tissue_only)
  if(last_out MATCHES "libpalpate")
    message(FATAL_ERROR "a static palpate, yet the program loads a palpate library:\n${last_out}")
  endif()
  file(GLOB_RECURSE archives ${WORK_DIR}/build/*libpalpate_tissue.a)
  if(NOT archives)
    message(FATAL_ERROR "no libpalpate_tissue.a was built")
  endif()
else()
  message(FATAL_ERROR "MODE must be pkgconfig, component or subproject, not '${MODE}'")
endif()
