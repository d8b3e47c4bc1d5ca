# Installs the built palpate into a scratch prefix, then configures, builds and runs an example
# (EMBED_SOURCE_DIR: examples/embed, examples/tissue_only) against it with find_package(palpate),
# as a user's project would: its program EMBED_PROGRAM run with EMBED_ARGS must print something
# matching EMBED_EXPECT, and, when EMBED_FORBID is set, none of the shared libraries it loads
# (ldd: the whole closure) may match it.
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
  message(FATAL_ERROR "configuring ${EMBED_SOURCE_DIR} against the installed palpate failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build -j2 RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building ${EMBED_SOURCE_DIR} failed")
endif()
separate_arguments(args UNIX_COMMAND "${EMBED_ARGS}")
execute_process(COMMAND ${WORK_DIR}/build/${EMBED_PROGRAM} ${args}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(rc OR NOT out MATCHES "${EMBED_EXPECT}")
  message(FATAL_ERROR "${EMBED_PROGRAM} did not run as expected (exit ${rc}; expected output matching '${EMBED_EXPECT}')")
endif()
if(EMBED_FORBID)
  execute_process(COMMAND ldd ${WORK_DIR}/build/${EMBED_PROGRAM} RESULT_VARIABLE rc OUTPUT_VARIABLE libs)
  if(rc)
    message(FATAL_ERROR "ldd ${EMBED_PROGRAM} failed")
  endif()
  message("${EMBED_PROGRAM} loads:\n${libs}")
  string(REGEX MATCHALL "[^ \t\n]*(${EMBED_FORBID})[^ \t\n]*" found "${libs}")
  if(found)
    message(FATAL_ERROR "${EMBED_PROGRAM} loads libraries it must not need: ${found}")
  endif()
  if(NOT libs MATCHES "libpalpate_tissue")
    message(FATAL_ERROR "${EMBED_PROGRAM} does not load libpalpate_tissue: is the check looking at the right program?")
  endif()
endif()
