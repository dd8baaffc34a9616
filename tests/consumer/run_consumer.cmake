# Run by the ctests "cmake package: …" (tests/CMakeLists.txt), with cmake -P:
#   MODE=package       install BUILD_DIR into WORK/prefix, build tests/consumer with find_package
#   MODE=pkg-config    install BUILD_DIR into WORK/prefix, compile tests/consumer/main.cpp with
#                      the flags of `pkg-config --static sombra` (CXX_COMPILER), no CMake
#   MODE=subdirectory  build tests/consumer with add_subdirectory(SOURCE_DIR)
# then run the consumer, which renders a tiny procedural scene (exit code 0 and "OK" expected).
foreach(v MODE WORK SOURCE_DIR BUILD_DIR)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "run_consumer.cmake: -D${v}= missing")
  endif()
endforeach()

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK})
set(args -S ${SOURCE_DIR}/tests/consumer -B ${WORK}/build -DCMAKE_BUILD_TYPE=Release)
if(CXX_COMPILER)
  list(APPEND args -DCMAKE_CXX_COMPILER=${CXX_COMPILER})
endif()
if(MODE STREQUAL "package")
  run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK}/prefix)
  # Nothing of the source or build tree may be needed: the prefix alone.
  list(APPEND args -DCMAKE_PREFIX_PATH=${WORK}/prefix -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON)
elseif(MODE STREQUAL "subdirectory")
  # what is tested is that add_subdirectory configures, builds and links, not the code's speed:
  # unoptimised, without debug information and as a unity build (a batch of sources per compile)
  # the library compiles in far less time
  list(APPEND args -DSOMBRA_SOURCE_DIR=${SOURCE_DIR} -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O0
       -DCMAKE_C_FLAGS_DEBUG=-O0 -DCMAKE_UNITY_BUILD=ON)
elseif(NOT MODE STREQUAL "pkg-config")
  message(FATAL_ERROR "run_consumer.cmake: unknown MODE ${MODE}")
endif()
if(MODE STREQUAL "pkg-config")
  run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK}/prefix)
  file(GLOB_RECURSE pc ${WORK}/prefix/*/sombra.pc)
  get_filename_component(pcdir "${pc}" DIRECTORY)
  set(ENV{PKG_CONFIG_PATH} ${pcdir})
  run(pkg-config --cflags --libs --static sombra)
  string(STRIP "${out}" flags)
  separate_arguments(flags UNIX_COMMAND "${flags}")
  file(MAKE_DIRECTORY ${WORK}/build)
  run(${CXX_COMPILER} -std=c++17 -O1 ${SOURCE_DIR}/tests/consumer/main.cpp ${flags} -o ${WORK}/build/consumer)
else()
  run(${CMAKE_COMMAND} ${args})
  run(${CMAKE_COMMAND} --build ${WORK}/build -j2 --target consumer)
endif()
run(${WORK}/build/consumer)
message("${out}")
if(NOT out MATCHES "sombra consumer: OK")
  message(FATAL_ERROR "consumer did not print OK")
endif()
