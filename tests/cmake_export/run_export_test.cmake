# Installs the build into a private prefix, then configures and builds the consumer project
# against it, runs its program, and loads its plugins into the installed kinolab. Run with
# cmake -P; fails on the first step that does not do what it should.
file(REMOVE_RECURSE "${WORK_DIR}")

# run_step(EXPECT 0|FAIL COMMAND ...): the output lands in step_output.
function(run_step expect)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE result OUTPUT_VARIABLE output
                  ERROR_VARIABLE output)
  if(expect STREQUAL "OK" AND NOT result EQUAL 0)
    message(FATAL_ERROR "step failed: ${ARGN}\n${output}")
  elseif(expect STREQUAL "FAIL" AND result EQUAL 0)
    message(FATAL_ERROR "step should have failed: ${ARGN}\n${output}")
  endif()
  set(step_output "${output}" PARENT_SCOPE)
endfunction()

function(expect_output pattern)
  if(NOT step_output MATCHES "${pattern}")
    message(FATAL_ERROR "expected output matching '${pattern}', got:\n${step_output}")
  endif()
endfunction()

set(prefix "${WORK_DIR}/prefix")
set(build "${WORK_DIR}/build")
run_step(OK ${CMAKE_COMMAND} --install "${KINOLAB_BUILD_DIR}" --prefix "${prefix}")
run_step(OK ${CMAKE_COMMAND} -S "${CONSUMER_SOURCE_DIR}" -B "${build}"
         -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release
         -DKINOLAB_SOURCE_DIR=${CONSUMER_SOURCE_DIR}/../..)
run_step(OK ${CMAKE_COMMAND} --build "${build}")

run_step(OK "${build}/consumer")
expect_output("kinolab [0-9]+\\.[0-9]+\\.[0-9]+ distance 0\\.45")

# The installed command loads the plugin and lists it beside the built-in samplers.
set(kinolab "${prefix}/bin/kinolab")
# Its planners loaded on use find their installed module (lib/kinolab_modules) and plan.
run_step(OK "${kinolab}" plan --world "${CONSUMER_SOURCE_DIR}/../../configs/worlds/empty.yaml"
         --planner rrtstar_ceres --set time_limit=0.5 --set back_end=bspline
         --start 2,2,1 --goal 12,10,2 --cache-dir "${WORK_DIR}/cache")
expect_output("\"status\":\"exact\"")
run_step(OK "${kinolab}" --plugin "${build}/libaxes_sampler.so" list samplers --json)
expect_output("\"key\": \"axes\"")
expect_output("\"origin\": \"[^\"]*libaxes_sampler.so\"")
expect_output("\"key\": \"uniform\"")

# The plugin passes the sampler conformance suite, run by the installed conformance runner.
run_step(OK "${kinolab}" test-plugin "${build}/libaxes_sampler.so")
expect_output("testing sampler 'axes'")
expect_output("2 tests: 2 passed, 0 FAILED")

# Broken libraries are refused, naming the library and the reason.
run_step(FAIL "${kinolab}" --plugin "${build}/libclashing_sampler.so" list)
expect_output("sampler 'uniform' from [^ ]*libclashing_sampler.so is already registered")
# The example planner builds out of tree as it is; its key is the built-in one, so loading it
# into kinolab is refused by name (a researcher's copy gets its own key).
run_step(FAIL "${kinolab}" --plugin "${build}/libgreedy_mp.so" list planners)
expect_output("planner 'greedy_mp' from [^ ]*libgreedy_mp.so is already registered; pick another key")
run_step(FAIL "${kinolab}" --plugin "${build}/libno_entry_point.so" list)
expect_output("libno_entry_point.so': no kinolab entry point")
run_step(FAIL "${kinolab}" --plugin "${build}/libmissing.so" list)
expect_output("libmissing.so': no such file")
# The out-of-tree extensions (a world generator, a lower bound, a heuristic, a sensor, a
# vehicle map) are listed beside the built-in ones of their kinds.
set(extensions "${build}/libextensions_plugin.so")
foreach(kind_key worlds:pillar_row lower_bounds:scaled_endpoint heuristics:scaled_time_optimal
        sensors:ring vehicle_maps:obstacles_only)
  string(REPLACE ":" ";" kind_key "${kind_key}")
  list(GET kind_key 0 kind)
  list(GET kind_key 1 key)
  run_step(OK "${kinolab}" --plugin "${extensions}" list ${kind} --json)
  expect_output("\"key\": \"${key}\"")
  expect_output("\"origin\": \"[^\"]*libextensions_plugin.so\"")
endforeach()

# They pass their kinds' conformance suites (tests/conformance/extension_conformance_test.cpp):
# the heuristic consistent, the bound below the full cost and lazy = eager with it, the
# sensor's rays, the map's knowledge, the generator's grid.
run_step(OK "${kinolab}" test-plugin "${extensions}")
expect_output("6 tests: 6 passed, 0 FAILED")

# Lazy search with the out-of-tree bound and heuristic returns eager's cost (both stay a lower
# bound and consistent), chosen by key with their own parameters nested.
set(world "${CONSUMER_SOURCE_DIR}/../support/small_forest.yaml")
set(env ${CMAKE_COMMAND} -E env "KINOLAB_CACHE_DIR=${WORK_DIR}/cache")
set(common --set sampler.samples_per_axis=3 --set heuristic_weight=1 --start 1,1,1.5 --goal 8.5,8,1.5)
run_step(OK ${env} "${kinolab}" --plugin "${extensions}" plan --world "${world}"
         --planner lazy_mp_astar ${common} --set lower_bound=scaled_endpoint
         --set lower_bound.scale=0.25 --set heuristic=scaled_time_optimal
         --set heuristic.scale=0.5)
string(REGEX MATCH "{[^\n]*}[\n]*$" json "${step_output}")
string(JSON status GET "${json}" status)
string(JSON lazy_cost GET "${json}" cost)
if(NOT status STREQUAL "exact")
  message(FATAL_ERROR "lazy with the extensions: status ${status}\n${step_output}")
endif()
run_step(OK ${env} "${kinolab}" plan --world "${world}" --planner eager_mp_astar ${common})
string(REGEX MATCH "{[^\n]*}[\n]*$" json "${step_output}")
string(JSON eager_cost GET "${json}" cost)
# Equal up to floating-point ties: the first 9 characters of the printed costs.
string(SUBSTRING "${lazy_cost}" 0 9 lazy_prefix)
string(SUBSTRING "${eager_cost}" 0 9 eager_prefix)
if(NOT lazy_prefix STREQUAL eager_prefix)
  message(FATAL_ERROR "lazy with the extensions: cost ${lazy_cost} != eager ${eager_cost}")
endif()

# A flight experiment that uses all five: a world with the pillar row, the ring sensor, the
# obstacles-only map, the bound and the heuristic.
file(READ "${world}" world_text)
string(REPLACE "\n" "\n      " world_text "${world_text}")
function(write_experiment path world_count heuristic_scale bound_scale sensor_beams map_hits)
  file(WRITE "${path}" "kind: flight\nname: extensions\nseed: 4\nplugins: [${extensions}]\n"
    "worlds:\n  - id: small\n    spec:\n      ${world_text}\n"
    "        - {type: pillar_row, y: 4.5, ${world_count}: 2, width: 0.4, height: 3}\n"
    "queries:\n  fixed:\n    - {start: [1, 1, 1.5], goal: [8.5, 8, 1.5]}\n"
    "planners:\n  - id: scaled\n    type: lazy_mp_astar\n"
    "    sampler: {type: uniform, params: {samples_per_axis: 3}}\n"
    "    params:\n"
    "      heuristic: {type: scaled_time_optimal, ${heuristic_scale}: 0.5}\n"
    "      lower_bound: {type: scaled_endpoint, ${bound_scale}: 0.25}\n"
    "flight:\n  sensor: {type: ring, ${sensor_beams}: 90, range: 4}\n"
    "  map: {type: obstacles_only, ${map_hits}: 2}\n  max_time: 30\n")
endfunction()
write_experiment("${WORK_DIR}/extensions.yaml" count scale scale beams hits)
run_step(OK ${env} "${kinolab}" run "${WORK_DIR}/extensions.yaml" --out "${WORK_DIR}/extensions")
expect_output("1 runs? ran")
run_step(OK ${env} "${kinolab}" report "${WORK_DIR}/extensions" --out "${WORK_DIR}/extensions/report")
# A misspelt parameter of each extension is refused before anything runs, with its file, line
# and the parameter's owner.
foreach(misspelt "cuont;scale;scale;beams;hits;world 'pillar_row'"
        "count;scael;scale;beams;hits;heuristic 'scaled_time_optimal'"
        "count;scale;scael;beams;hits;lower_bound 'scaled_endpoint'"
        "count;scale;scale;beasm;hits;sensor 'ring'"
        "count;scale;scale;beams;hist;vehicle_map 'obstacles_only'")
  list(GET misspelt 0 world_count)
  list(GET misspelt 1 heuristic_scale)
  list(GET misspelt 2 bound_scale)
  list(GET misspelt 3 sensor_beams)
  list(GET misspelt 4 map_hits)
  list(GET misspelt 5 owner)
  write_experiment("${WORK_DIR}/misspelt.yaml" ${world_count} ${heuristic_scale} ${bound_scale}
                   ${sensor_beams} ${map_hits})
  run_step(FAIL ${env} "${kinolab}" run "${WORK_DIR}/misspelt.yaml" --out "${WORK_DIR}/misspelt" --dry-run)
  expect_output("misspelt.yaml:[0-9]+:[0-9]+: [^\n]*${owner}: unknown parameter '(scael|beasm|cuont|hist)' \\(did you mean '(scale|beams|count|hits)'")
endforeach()
message(STATUS "out-of-tree program and plugins: as expected")
