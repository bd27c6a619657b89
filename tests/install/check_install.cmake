# CTest script (cmake -P): install the build tree MR_BUILD_DIR into a
# temporary prefix under MR_WORK_DIR, then build tests/install/consumer.c
# against it through pkg-config (shared, and --static) and through
# find_package(meshreduce) (meshreduce::meshreduce and
# meshreduce::meshreduce_static), and run each program.
set(prefix ${MR_WORK_DIR}/prefix)
file(REMOVE_RECURSE ${MR_WORK_DIR})
file(MAKE_DIRECTORY ${MR_WORK_DIR})

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  set(run_out "${out}" PARENT_SCOPE)
endfunction()

run(${CMAKE_COMMAND} --install ${MR_BUILD_DIR} --prefix ${prefix})

foreach(f include/meshreduce.h share/man/man1/meshreduce.1 bin/meshreduce)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
file(GLOB pc ${prefix}/lib*/pkgconfig/meshreduce.pc ${prefix}/lib/*/pkgconfig/meshreduce.pc)
file(GLOB cfg ${prefix}/lib*/cmake/meshreduce/meshreduceConfig.cmake
              ${prefix}/lib/*/cmake/meshreduce/meshreduceConfig.cmake)
if(NOT pc OR NOT cfg)
  message(FATAL_ERROR "meshreduce.pc (${pc}) or meshreduceConfig.cmake (${cfg}) not installed")
endif()
get_filename_component(pcdir ${pc} DIRECTORY)
get_filename_component(libdir ${pcdir} DIRECTORY)

# pkg-config, shared: the program finds the library through its rpath.
find_program(PKG_CONFIG pkg-config REQUIRED)
set(ENV{PKG_CONFIG_PATH} ${pcdir})
run(${PKG_CONFIG} --cflags --libs meshreduce)
string(STRIP "${run_out}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${MR_C_COMPILER} ${MR_SOURCE_DIR}/tests/install/consumer.c ${flags} -Wl,-rpath,${libdir}
    -o ${MR_WORK_DIR}/pc_shared)
run(${MR_WORK_DIR}/pc_shared)
message(STATUS "pkg-config shared: ${run_out}")
# pkg-config --static: the program carries the library, links OpenMP and
# libpng from Libs.private / Requires.private.
run(${PKG_CONFIG} --static --cflags --libs meshreduce)
string(STRIP "${run_out}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(${MR_C_COMPILER} ${MR_SOURCE_DIR}/tests/install/consumer.c -static-libgcc
    -Wl,-Bstatic -L${libdir} -lmeshreduce -Wl,-Bdynamic ${flags} -o ${MR_WORK_DIR}/pc_static)
run(ldd ${MR_WORK_DIR}/pc_static)
if(run_out MATCHES "libmeshreduce")
  message(FATAL_ERROR "pc_static links libmeshreduce.so:\n${run_out}")
endif()
run(${MR_WORK_DIR}/pc_static)
message(STATUS "pkg-config static: ${run_out}")

# find_package(meshreduce), both targets.
run(${CMAKE_COMMAND} -S ${MR_SOURCE_DIR}/tests/install -B ${MR_WORK_DIR}/consumer
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_C_COMPILER=${MR_C_COMPILER}
    -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${MR_WORK_DIR}/consumer)
foreach(exe consumer_shared consumer_static)
  run(${MR_WORK_DIR}/consumer/${exe})
  message(STATUS "find_package ${exe}: ${run_out}")
endforeach()
run(ldd ${MR_WORK_DIR}/consumer/consumer_static)
if(run_out MATCHES "libmeshreduce")
  message(FATAL_ERROR "consumer_static links libmeshreduce.so:\n${run_out}")
endif()
