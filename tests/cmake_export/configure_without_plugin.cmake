# Configures a copy of the source tree without the folders that use OMPL or Ceres
# (plugins/planners/rrtstar_ceres and the B-spline back end, plugins/back_ends/bspline). The
# build must configure, and find neither library.
# Run with cmake -P -DSOURCE_DIR=... -DWORK_DIR=...
file(REMOVE_RECURSE "${WORK_DIR}")
set(copy "${WORK_DIR}/source")
file(MAKE_DIRECTORY "${copy}")
foreach(item CMakeLists.txt cmake framework plugins analysis python viewer)
  file(COPY "${SOURCE_DIR}/${item}" DESTINATION "${copy}")
endforeach()
if(NOT EXISTS "${copy}/plugins/planners/rrtstar_ceres/CMakeLists.txt")
  message(FATAL_ERROR "the copy has no rrtstar_ceres folder to remove: is SOURCE_DIR right?")
endif()
foreach(folder planners/rrtstar_ceres back_ends/bspline)
  file(REMOVE_RECURSE "${copy}/plugins/${folder}")
endforeach()
execute_process(
  COMMAND ${CMAKE_COMMAND} -S "${copy}" -B "${WORK_DIR}/build" -DCMAKE_BUILD_TYPE=Release
          -DKINOLAB_BUILD_TESTS=OFF -DKINOLAB_BUILD_BENCHMARKS=OFF
  RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "configure without rrtstar_ceres failed:\n${output}")
endif()
file(READ "${WORK_DIR}/build/CMakeCache.txt" cache)
foreach(library ompl Ceres)
  if(cache MATCHES "\n${library}_DIR:")
    message(FATAL_ERROR "configure without rrtstar_ceres still looked up ${library}")
  endif()
endforeach()
message(STATUS "configured without rrtstar_ceres; OMPL and Ceres were not looked up")
