# A build without an optional component links none of its libraries: no layer's shared library
# (LIBS) names one matching FORBID among its direct dependencies (objdump -p: NEEDED).
foreach(lib IN LISTS LIBS)
  execute_process(COMMAND objdump -p ${lib} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
  if(rc)
    message(FATAL_ERROR "objdump -p ${lib} failed")
  endif()
  string(REGEX MATCHALL "NEEDED +[^\n]+" needed "${out}")
  message("${lib}: ${needed}")
  string(REGEX MATCHALL "[^ ;]*(${FORBID})[^ ;]*" found "${needed}")
  if(found)
    message(FATAL_ERROR "${lib} links what this build was configured without: ${found}")
  endif()
endforeach()
