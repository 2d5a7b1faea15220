# ctest: installs this build into a scratch prefix, builds examples/consumer against the installed
# package (find_package(microshadow CONFIG)) and runs it; then configures the consumer with
# add_subdirectory of the source tree (configure only: the build is the same targets).
# Inputs: BUILD_DIR, SOURCE_DIR, WORK_DIR, CXX_COMPILER; optional CXX_LAUNCHER, SANITIZE (the
# libraries were built with ASan + UBSan: the consumer must link the same runtimes).
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "failed (${status}): ${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(compiler -DCMAKE_CXX_COMPILER=${CXX_COMPILER})
if(CXX_LAUNCHER)
  list(APPEND compiler -DCMAKE_CXX_COMPILER_LAUNCHER=${CXX_LAUNCHER})
endif()
if(SANITIZE)
  list(APPEND compiler "-DCMAKE_CXX_FLAGS=-fsanitize=address,undefined" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
endif()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
foreach(header microshadow.hpp types.hpp evaluate.hpp lut.hpp)
  if(NOT EXISTS ${WORK_DIR}/prefix/include/microshadow/${header})
    message(FATAL_ERROR "not installed: include/microshadow/${header}")
  endif()
endforeach()
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/installed -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix ${compiler})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/installed)
run(${WORK_DIR}/installed/consumer ${WORK_DIR})
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/subdirectory -DCMAKE_BUILD_TYPE=Release
    -DMICROSHADOW_SOURCE_DIR=${SOURCE_DIR} ${compiler})
