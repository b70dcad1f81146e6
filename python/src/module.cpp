// kinolab._core: the Python bindings (pybind11). The Pythonic layer is kinolab/__init__.py;
// the module binds the framework's own objects: worlds (NumPy views of the grid and ESDF),
// the plugin registries, planners and their results, the experiment runner. Planning and
// running release the GIL; kinolab's errors become Python exceptions with the same message.
// This file binds the errors and the runner and defines the module; the rest is bound in
// world_bindings.cpp, plugin_bindings.cpp and planner_bindings.cpp (bindings.hpp).
#include <chrono>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/version.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/runner.hpp"
#include "kinolab/world/world_cache.hpp"

namespace kinolab::python {
namespace {

py::dict runExperimentFile(const std::string& path, const std::string& out, int jobs, bool resume,
                           const std::string& shard, const std::string& cache_dir,
                           const py::object& progress) {
  const Experiment experiment = Experiment::fromFile(path);
  RunnerOptions options;
  options.out_dir = out;
  options.jobs = jobs;
  options.resume = resume;
  if (!shard.empty()) options.shard = Shard::parse(shard);
  options.cache_dir = cache_dir.empty() ? WorldCache::defaultDirectory() : cache_dir;
  if (!progress.is_none()) {
    options.on_progress = [&progress](const RunnerProgress& state) {
      py::gil_scoped_acquire acquire;
      progress(state.done, state.total, state.unsolved, state.seconds);
    };
  }
  RunnerSummary summary;
  {
    py::gil_scoped_release release;
    summary = runExperiment(experiment, options);
  }
  py::dict dict;
  dict["planned"] = summary.planned;
  dict["skipped"] = summary.skipped;
  dict["finished"] = summary.finished;
  dict["succeeded"] = summary.succeeded;
  dict["by_status"] = summary.by_status;
  dict["interrupted"] = summary.interrupted;
  dict["seconds"] = summary.seconds;
  dict["database"] = out + "/results.sqlite";
  return dict;
}

/// kinolab::Error and its subclasses, with the same messages.
void bindErrors(py::module_& m) {
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  static py::exception<ConfigError> config_error(m, "ConfigError", error.ptr());
  static py::exception<ParameterConflict> conflict(m, "ParameterConflict", config_error.ptr());
  static py::exception<FileError> file_error(m, "FileError", error.ptr());
  static py::exception<PluginError> plugin_error(m, "PluginError", error.ptr());
  static py::exception<InvalidArgument> invalid(m, "InvalidArgument", error.ptr());
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const ParameterConflict& e) {
      conflict(e.what());
    } catch (const ConfigError& e) {
      config_error(e.what());
    } catch (const FileError& e) {
      file_error(e.what());
    } catch (const PluginError& e) {
      plugin_error(e.what());
    } catch (const InvalidArgument& e) {
      invalid(e.what());
    } catch (const Error& e) {
      error(e.what());
    }
  });
}

}  // namespace
}  // namespace kinolab::python

PYBIND11_MODULE(_core, m) {
  using namespace kinolab;
  using namespace kinolab::python;
  m.doc() = "kinolab's C++ core (see the kinolab package for the documented API)";
  m.attr("__version__") = kVersion;
  registerBuiltinPlugins();
  bindErrors(m);
  bindWorld(m);
  bindPlugins(m);
  bindPlanner(m);
  bindResult(m);
  bindScene(m);
  m.def("run_experiment", &runExperimentFile);
  // For benchmarks/python_overhead.py: the wall time (ms) of each of `repeats` plans called
  // from C++, the reference a plan called from Python is compared with.
  m.def("_plan_wall_ms",
        [](PyPlanner& self, const py::object& start, const py::object& goal, int repeats) {
          PlanningQuery query;
          query.start = startState(start, py::none(), py::none());
          query.goal = vector3(goal, "goal");
          std::vector<double> times;
          py::gil_scoped_release release;
          for (int i = 0; i < repeats; ++i) {
            const auto begin = std::chrono::steady_clock::now();
            const PlanResult result = self.configured.planner->plan(query, Budget{});
            times.push_back(
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin)
                    .count());
          }
          return times;
        });
}
