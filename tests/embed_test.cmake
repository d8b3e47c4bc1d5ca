# Installs the built palpate into a scratch prefix, then configures, builds and runs
# examples/embed against it with find_package(palpate) — as a user's project would.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${PALPATE_BINARY_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
if(NOT EXISTS ${WORK_DIR}/prefix/include/palpate/palpate.h)
  message(FATAL_ERROR "public headers were not installed")
endif()
file(GLOB_RECURSE internal ${WORK_DIR}/prefix/include/*/factory.h)
if(internal)
  message(FATAL_ERROR "internal headers were installed: ${internal}")
endif()
set(sanitize_flags)
if(EMBED_SANITIZE)
  set(sanitize_flags -DCMAKE_CXX_FLAGS=-fsanitize=${EMBED_SANITIZE} -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=${EMBED_SANITIZE})
endif()
# The user's compiler is palpate's: a sanitizer's runtime must be the one the library was built for.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${EMBED_SOURCE_DIR} -B ${WORK_DIR}/build
                -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release ${sanitize_flags}
                -DCMAKE_CXX_COMPILER=${EMBED_CXX_COMPILER}
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring examples/embed against the installed palpate failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build -j2 RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building examples/embed failed")
endif()
execute_process(COMMAND ${WORK_DIR}/build/embed ${PALPATE_DATA_DIR}/meshes/liver.msh
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(rc OR NOT out MATCHES "181 vertices, 596 tetrahedra")
  message(FATAL_ERROR "examples/embed did not run as expected (exit ${rc})")
endif()
