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
run_step(OK "${kinolab}" --plugin "${build}/libaxes_sampler.so" list samplers --json)
expect_output("\"key\": \"axes\"")
expect_output("\"origin\": \"[^\"]*libaxes_sampler.so\"")
expect_output("\"key\": \"uniform\"")

# The plugin passes the sampler conformance suite.
run_step(OK ${CMAKE_COMMAND} -E env "KINOLAB_TEST_PLUGINS=${build}/libaxes_sampler.so"
         "${TEST_BINARY}" "--gtest_filter=Registered/SamplerConformance.*/axes")
expect_output("PASSED.* 2 tests")

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
# The out-of-tree lower bound plans with eager's cost, and an experiment uses it.
set(bound "${build}/liblower_bound_plugin.so")
set(world "${CONSUMER_SOURCE_DIR}/../support/small_forest.yaml")
set(env ${CMAKE_COMMAND} -E env "KINOLAB_CACHE_DIR=${WORK_DIR}/cache")
foreach(planner lazy_scaled_bound eager_mp_astar)
  run_step(OK ${env} "${kinolab}" --plugin "${bound}" plan --world "${world}" --planner ${planner}
           --set sampler.samples_per_axis=3 --set heuristic_weight=1 --start 1,1,1.5
           --goal 8.5,8,1.5)
  string(REGEX MATCH "{[^\n]*}[\n]*$" json "${step_output}")
  string(JSON status GET "${json}" status)
  string(JSON cost_${planner} GET "${json}" cost)
  if(NOT status STREQUAL "exact")
    message(FATAL_ERROR "${planner}: status ${status}\n${step_output}")
  endif()
endforeach()
# Equal up to floating-point ties: the first 9 characters of the printed costs.
string(SUBSTRING "${cost_lazy_scaled_bound}" 0 9 lazy_cost)
string(SUBSTRING "${cost_eager_mp_astar}" 0 9 eager_cost)
if(NOT lazy_cost STREQUAL eager_cost)
  message(FATAL_ERROR "lazy_scaled_bound cost ${cost_lazy_scaled_bound} != eager ${cost_eager_mp_astar}")
endif()
file(READ "${world}" world_text)
string(REPLACE "\n" "\n      " world_text "${world_text}")
file(WRITE "${WORK_DIR}/bound.yaml" "kind: planning\nname: bound\nseed: 4\nplugins: [${bound}]\n"
  "worlds:\n  - id: small\n    spec:\n      ${world_text}\n"
  "queries:\n  random: {count: 3, min_distance: 3, max_distance: 7}\n"
  "planners:\n  - id: scaled\n    type: lazy_scaled_bound\n"
  "    sampler: {type: uniform, params: {samples_per_axis: 3}}\n"
  "    params: {bound_scale: 0.25, tau: 0.4}\n")
run_step(OK ${env} "${kinolab}" run "${WORK_DIR}/bound.yaml" --out "${WORK_DIR}/bound")
expect_output("3 runs ran, 3 succeeded")
message(STATUS "out-of-tree program and plugins: as expected")
