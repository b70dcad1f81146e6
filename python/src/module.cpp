// kinolab._core: the Python bindings (pybind11). The Pythonic layer is kinolab/__init__.py;
// this file binds the framework's own objects: worlds (NumPy views of the grid and ESDF),
// the plugin registries, planners and their results, the experiment runner. Planning and
// running release the GIL; kinolab's errors become Python exceptions with the same message.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/version.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/experiment/runner.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/view/scene.hpp"
#include "kinolab/world/world_cache.hpp"
#include "kinolab/world/world_spec.hpp"

namespace py = pybind11;

namespace kinolab::python {
namespace {

/// A built world and how it was obtained (built, or loaded from the cache).
struct PyWorld {
  std::shared_ptr<const World> world;
  std::string source = "built";
  double seconds = 0.0;
  std::string cache_file;
};

PyWorld loadWorld(const WorldSpec& spec, bool cache, const std::string& cache_dir) {
  PyWorld result;
  if (!cache) {
    const auto begin = std::chrono::steady_clock::now();
    result.world = World::build(spec);
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    return result;
  }
  const WorldLoad load =
      WorldCache(cache_dir.empty() ? WorldCache::defaultDirectory() : cache_dir).loadOrBuild(spec);
  result.world = load.world;
  result.source = load.source == WorldSource::kCache ? "cache" : "built";
  result.seconds = load.seconds;
  result.cache_file = load.cache_file;
  return result;
}

/// A read-only NumPy view of `data` (C order, shape dims) that keeps `owner` alive.
template <typename T>
py::array arrayView(const T* data, const Eigen::Vector3i& dims, py::handle owner) {
  const std::vector<py::ssize_t> shape = {dims.x(), dims.y(), dims.z()};
  const auto item = static_cast<py::ssize_t>(sizeof(T));
  const std::vector<py::ssize_t> strides = {item * dims.y() * dims.z(), item * dims.z(), item};
  py::array array(py::dtype::of<T>(), shape, strides, data, owner);
  py::detail::array_proxy(array.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return array;
}

/// Points as an (n, 3) array of doubles: one point (3,) or many (n, 3).
py::array_t<double, py::array::c_style | py::array::forcecast> points3(const py::object& points) {
  auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(points);
  if (!array ||
      !((array.ndim() == 2 && array.shape(1) == 3) || (array.ndim() == 1 && array.shape(0) == 3))) {
    throw InvalidArgument("points: expected an array of shape (n, 3) or (3,) (metres)");
  }
  return array;
}

py::object distances(const PyWorld& self, const py::object& points, bool with_gradient) {
  const auto input = points3(points);
  const py::ssize_t n = input.ndim() == 1 ? 1 : input.shape(0);
  py::array_t<double> distance(n);
  py::array_t<double> gradient(std::vector<py::ssize_t>{n, 3});
  const double* in = input.data();
  double* d = distance.mutable_data();
  double* g = gradient.mutable_data();
  {
    // Rows of three contiguous doubles are Eigen::Vector3d's layout: the batched queries
    // (Esdf::distances, the same values as one at a time) read and write the arrays in place.
    static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double));
    py::gil_scoped_release release;
    const Esdf& esdf = self.world->esdf();
    const auto count = static_cast<std::size_t>(n);
    const std::span points_in(reinterpret_cast<const Eigen::Vector3d*>(in), count);
    if (with_gradient) {
      esdf.distancesWithGradients(points_in, std::span(d, count),
                                  std::span(reinterpret_cast<Eigen::Vector3d*>(g), count));
    } else {
      esdf.distances(points_in, std::span(d, count));
    }
  }
  if (input.ndim() == 1) {
    if (!with_gradient) return py::float_(d[0]);
    return py::make_tuple(d[0], gradient.attr("reshape")(3));
  }
  if (!with_gradient) return distance;
  return py::make_tuple(distance, gradient);
}

py::object parameterValue(const ParameterValue& value) {
  return std::visit([](const auto& v) -> py::object { return py::cast(v); }, value);
}

py::list parameterList(const ParameterSpecs& specs) {
  py::list list;
  for (const ParameterSpec& spec : specs.all()) {
    py::dict item;
    item["name"] = spec.name;
    item["type"] = spec.typeName();
    item["default"] = parameterValue(spec.default_value);
    item["range"] = spec.rangeText();
    item["doc"] = spec.doc;
    list.append(item);
  }
  return list;
}

py::list metricList(const MetricSpecs& specs) {
  py::list list;
  for (const MetricSpec& spec : specs.all()) {
    py::dict item;
    item["name"] = spec.name;
    item["type"] = spec.typeName();
    item["unit"] = spec.unit;
    item["clock"] = spec.clock;
    item["series"] = spec.series;
    item["doc"] = spec.doc;
    list.append(item);
  }
  return list;
}

/// The plugins of one kind ("planners", "heuristics", ...: kinolab list's names) with their
/// parameters and statistics.
py::list pluginList(const std::string& kind) {
  const PluginRegistryBase* registry = findPluginRegistry(kind);
  if (!registry) {
    std::vector<std::string> kinds;
    for (const PluginRegistryBase* known : pluginRegistries()) kinds.push_back(known->plural());
    throw InvalidArgument("unknown plugin kind '" + kind + "'" + didYouMean(kind, kinds) +
                          "; kinds: " + join(kinds, ", "));
  }
  py::list list;
  for (const PluginInfo* info : registry->list()) {
    py::dict item;
    item["key"] = info->key;
    item["description"] = info->description;
    item["origin"] = info->origin;
    item["parameters"] = parameterList(info->parameters);
    item["statistics"] = metricList(info->statistics);
    list.append(item);
  }
  return list;
}

/// A configured planner, set up on one world.
struct PyPlanner {
  ConfiguredPlanner configured;
  std::shared_ptr<const World> world;
};

/// A planning result: the framework's PlanResult, the planner's declared statistics and the
/// search tree when one was asked for.
struct PyResult {
  PlanResult result;
  const PluginInfo* planner = nullptr;  ///< its registration: the statistics it declares
  SearchTree tree;
  bool has_tree = false;
};

/// Three finite numbers (a point or a vector), named `name` in errors.
Eigen::Vector3d vector3(const py::object& value, const std::string& name) {
  const auto array = py::array_t<double, py::array::forcecast>::ensure(value);
  if (!array || array.size() != 3) throw InvalidArgument(name + ": expected three numbers x, y, z");
  const Eigen::Vector3d vector(array.data()[0], array.data()[1], array.data()[2]);
  if (!vector.allFinite()) throw InvalidArgument(name + ": not finite");
  return vector;
}

/// A start state: the position, and the velocity and acceleration when given (else zero).
ChainState startState(const py::object& position, const py::object& velocity,
                      const py::object& acceleration) {
  ChainState state = ChainState::Zero();
  state.col(0) = vector3(position, "start");
  if (!velocity.is_none()) state.col(1) = vector3(velocity, "start_velocity");
  if (!acceleration.is_none()) state.col(2) = vector3(acceleration, "start_acceleration");
  return state;
}

PyResult plan(PyPlanner& self, const py::object& start, const py::object& goal,
              const py::object& start_velocity, const py::object& start_acceleration,
              double time_limit, long long max_iterations, bool tree) {
  if (!self.world) throw InvalidArgument("plan: the planner has no world (planner.setup(world))");
  PlanningQuery query;
  query.start = startState(start, start_velocity, start_acceleration);
  query.goal = vector3(goal, "goal");
  if (!(time_limit > 0.0))
    throw InvalidArgument("time_limit: expected a positive number of seconds");
  if (max_iterations <= 0) throw InvalidArgument("max_iterations: expected a positive count");
  PyResult out;
  out.planner = self.configured.info;
  {
    py::gil_scoped_release release;
    out.result = self.configured.planner->plan(query, Budget{time_limit, max_iterations},
                                               tree ? &out.tree : nullptr);
  }
  out.has_tree = tree;
  return out;
}

py::dict trajectorySamples(const Trajectory& trajectory, double step) {
  if (!(step > 0.0)) throw InvalidArgument("step: expected a positive number of seconds");
  if (trajectory.duration() / step > 1e7) {
    throw InvalidArgument("step: more than 10,000,000 samples; use a larger step");
  }
  const std::vector<TrajectorySample> samples =
      trajectory.empty() ? std::vector<TrajectorySample>{} : trajectory.sample(step);
  const auto n = static_cast<py::ssize_t>(samples.size());
  py::array_t<double> time(n);
  py::array_t<double> columns[4] = {
      py::array_t<double>({n, py::ssize_t{3}}), py::array_t<double>({n, py::ssize_t{3}}),
      py::array_t<double>({n, py::ssize_t{3}}), py::array_t<double>({n, py::ssize_t{3}})};
  double* t = time.mutable_data();
  double* c[4] = {columns[0].mutable_data(), columns[1].mutable_data(), columns[2].mutable_data(),
                  columns[3].mutable_data()};
  for (py::ssize_t i = 0; i < n; ++i) {
    const TrajectorySample& sample = samples[static_cast<std::size_t>(i)];
    t[i] = sample.time;
    const Eigen::Vector3d* values[4] = {&sample.position, &sample.velocity, &sample.acceleration,
                                        &sample.jerk};
    for (int k = 0; k < 4; ++k) {
      for (int axis = 0; axis < 3; ++axis) c[k][3 * i + axis] = (*values[k])[axis];
    }
  }
  py::dict dict;
  dict["t"] = time;
  dict["position"] = columns[0];
  dict["velocity"] = columns[1];
  dict["acceleration"] = columns[2];
  dict["jerk"] = columns[3];
  return dict;
}

py::object treeArrays(const PyResult& self) {
  if (!self.has_tree) return py::none();
  const SearchTree& tree = self.tree;
  py::list points;
  py::list states;
  py::array_t<bool> closed(static_cast<py::ssize_t>(tree.size()));
  bool* c = closed.mutable_data();
  for (std::size_t i = 0; i < tree.size(); ++i) {
    const SearchTreeEdge& edge = tree[i];
    py::array_t<double> polyline({static_cast<py::ssize_t>(edge.points.size()), py::ssize_t{3}});
    double* p = polyline.mutable_data();
    for (std::size_t k = 0; k < edge.points.size(); ++k) {
      for (int axis = 0; axis < 3; ++axis) p[3 * k + axis] = edge.points[k][axis];
    }
    points.append(polyline);
    states.append(std::string(toString(edge.state)));
    c[i] = edge.closed;
  }
  py::dict dict;
  dict["points"] = points;
  dict["state"] = py::module_::import("numpy").attr("array")(states);
  dict["closed"] = closed;
  return dict;
}

/// The checker's verdict and its evaluation of the trajectory.
py::dict checkDict(const PlanResult& result) {
  const CheckResult& check = result.check;
  py::dict dict;
  dict["valid"] = check.valid;
  dict["check"] = check.check;
  dict["detail"] = check.detail;
  dict["time"] = check.time;
  dict["position"] = py::make_tuple(check.position.x(), check.position.y(), check.position.z());
  // The evaluation, typed as every run's (evaluationMetrics()).
  const MetricList<TrajectoryEvaluation>& evaluation = evaluationMetrics();
  for (const auto& [name, value] : evaluation.values(result.evaluation)) {
    if (const auto* number = std::get_if<double>(&value)) {
      dict[py::str(name)] = *number;
    } else if (const auto* text = std::get_if<std::string>(&value)) {
      dict[py::str(name)] = *text;
    } else {
      dict[py::str(name)] = py::none();
    }
  }
  dict["samples"] = check.samples;
  return dict;
}

/// Every metric of the result schema and every statistic, typed as `kinolab plan` prints
/// them (the same JSON, parsed).
py::dict metricsDict(const PyResult& self) {
  const py::object loads = py::module_::import("json").attr("loads");
  py::dict dict = loads(toJson(resultValues(self.result), resultMetrics()));
  const py::dict statistics =
      loads(toJson(statisticValues(self.result.statistics), declaredStatistics(*self.planner)));
  for (const auto& [key, value] : statistics) dict[key] = value;
  return dict;
}

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

}  // namespace
}  // namespace kinolab::python

namespace kinolab::python {
namespace {

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

void bindWorld(py::module_& m) {
  py::class_<PyWorld>(m, "World")
      .def_property_readonly("name", [](const PyWorld& w) { return w.world->name(); })
      .def_property_readonly("spec_hash",
                             [](const PyWorld& w) { return toHex(w.world->specHash()); })
      .def_property_readonly("resolution",
                             [](const PyWorld& w) { return w.world->grid().resolution(); })
      .def_property_readonly("origin",
                             [](const PyWorld& w) {
                               const Eigen::Vector3d& o = w.world->grid().origin();
                               return py::make_tuple(o.x(), o.y(), o.z());
                             })
      .def_property_readonly("shape",
                             [](const PyWorld& w) {
                               const Eigen::Vector3i& n = w.world->grid().dims();
                               return py::make_tuple(n.x(), n.y(), n.z());
                             })
      .def_property_readonly("bounds",
                             [](const PyWorld& w) {
                               const Box b = w.world->bounds();
                               return py::make_tuple(
                                   py::make_tuple(b.min.x(), b.min.y(), b.min.z()),
                                   py::make_tuple(b.max.x(), b.max.y(), b.max.z()));
                             })
      .def_readonly("source", &PyWorld::source)
      .def_readonly("seconds", &PyWorld::seconds)
      .def_readonly("cache_file", &PyWorld::cache_file)
      .def_property_readonly("occupancy",
                             [](py::object self) {
                               const PyWorld& w = self.cast<const PyWorld&>();
                               const VoxelGrid& grid = w.world->grid();
                               return arrayView(grid.occupancy().data(), grid.dims(), self);
                             })
      .def_property_readonly("esdf",
                             [](py::object self) {
                               const PyWorld& w = self.cast<const PyWorld&>();
                               const Esdf& esdf = w.world->esdf();
                               return arrayView(esdf.values().data(), esdf.dims(), self);
                             })
      .def("distance",
           [](const PyWorld& w, const py::object& points) { return distances(w, points, false); })
      .def("distance_with_gradient",
           [](const PyWorld& w, const py::object& points) { return distances(w, points, true); })
      .def("segment_free", [](const PyWorld& w, const py::object& a, const py::object& b,
                              double radius) {
        const auto pa = points3(a);
        const auto pb = points3(b);
        return w.world->segmentFree(Eigen::Vector3d(pa.data()), Eigen::Vector3d(pb.data()), radius);
      });

  m.def("world_from_file", [](const std::string& path, bool cache, const std::string& cache_dir) {
    return loadWorld(WorldSpec::fromFile(path), cache, cache_dir);
  });
  m.def("world_from_text",
        [](const std::string& text, const std::string& source, const std::string& directory,
           bool cache, const std::string& cache_dir) {
          return loadWorld(WorldSpec::fromText(text, source, directory), cache, cache_dir);
        });
  m.def("default_cache_dir", &WorldCache::defaultDirectory);
}

void bindPlugins(py::module_& m) {
  m.def("plugins", &pluginList, py::arg("kind"),
        "The plugins of a kind (planners, samplers, heuristics, lower_bounds, worlds, sensors, "
        "search_spaces) with their parameters");
  m.def("plugin_kinds", [] {
    std::vector<std::string> kinds;
    for (const PluginRegistryBase* registry : pluginRegistries())
      kinds.push_back(registry->plural());
    return kinds;
  });
  m.def("load_plugin", &loadPluginLibrary);
  m.def("metrics", [] {
    py::dict dict;
    dict["result"] = metricList(resultMetrics());
    dict["statistics"] = metricList(commonStatistics());
    return dict;
  });
}

void bindPlanner(py::module_& m) {
  py::class_<PyPlanner>(m, "Planner")
      .def(
          py::init([](const std::string& key, const std::vector<ParameterAssignment>& assignments) {
            return PyPlanner{configurePlanner(key, assignments), nullptr};
          }))
      .def_property_readonly("key", [](const PyPlanner& p) { return p.configured.info->key; })
      .def_property_readonly("parameters",
                             [](const PyPlanner& p) {
                               py::dict dict;
                               // As they are set: a plugin parameter's own as `NAME.PARAMETER`
                               // (`sampler.sigma`).
                               for (const auto& [name, value] : p.configured.parameters.flattened())
                                 dict[py::str(name)] = parameterValue(value);
                               return dict;
                             })
      .def("setup",
           [](PyPlanner& p, const PyWorld& world, std::uint64_t seed) {
             p.configured.planner->setup({world.world, seed});
             p.world = world.world;
           })
      .def("reset", [](PyPlanner& p) { p.configured.planner->reset(); })
      .def("plan", &plan);

  py::class_<ParameterAssignment>(m, "Assignment")
      .def(py::init([](std::string name, std::string value, std::string where) {
        return ParameterAssignment{std::move(name), std::move(value), std::move(where)};
      }));
}

void bindResult(py::module_& m) {
  py::class_<PyResult>(m, "Result",
                       "A plan's result: status, cost, times, the checker's verdict, every "
                       "metric, the trajectory and (when asked for) the search tree")
      .def_property_readonly(
          "status", [](const PyResult& r) { return std::string(toString(r.result.status)); },
          "exact, approximate, no_solution, timeout, invalid_start, invalid_goal or "
          "invalid_trajectory")
      .def_property_readonly(
          "message", [](const PyResult& r) { return r.result.message; },
          "why the planner stopped where it did, in words")
      .def_property_readonly(
          "success",
          [](const PyResult& r) { return isSuccess(r.result.status, r.result.check.valid); },
          "exact and accepted by the independent checker")
      .def_property_readonly(
          "cost", [](const PyResult& r) { return r.result.cost; },
          "the trajectory's cost (the planner's objective; inf without a trajectory)")
      .def_property_readonly(
          "distance_to_goal", [](const PyResult& r) { return r.result.distance_to_goal; },
          "D: the distance from the trajectory's end to the goal, metres")
      .def_property_readonly(
          "planning_time_ms", [](const PyResult& r) { return r.result.planning_time_ms; },
          "the plan's wall-clock time, milliseconds")
      .def_property_readonly(
          "duration", [](const PyResult& r) { return r.result.trajectory.duration(); },
          "the trajectory's duration, seconds")
      .def_property_readonly(
          "check", [](const PyResult& r) { return checkDict(r.result); },
          "the independent checker's verdict: valid, check, detail, min_clearance, ...")
      .def_property_readonly("metrics", &metricsDict,
                             "every metric of the schema and the planner's statistics, by name")
      .def_property_readonly(
          "progress",
          [](const PyResult& r) {
            py::list samples;
            for (const ProgressSample& sample : r.result.progress)
              samples.append(py::make_tuple(sample.name, sample.time_ms, sample.value));
            return samples;
          },
          "the anytime progress: (series, time_ms, value) samples of the planner's declared "
          "series, in time order")
      .def_property_readonly("tree", &treeArrays,
                             "the search tree (plan(tree=True)): edges as NumPy arrays, or None")
      .def(
          "trajectory",
          [](const PyResult& r, double step) {
            return trajectorySamples(r.result.trajectory, step);
          },
          py::arg("step") = 0.01,
          "The trajectory sampled every `step` seconds and at its end: t (n,), position, "
          "velocity, acceleration and jerk (n, 3) NumPy arrays")
      .def(
          "position",
          [](const PyResult& r, double t) {
            if (r.result.trajectory.empty()) throw InvalidArgument("position: no trajectory");
            const Eigen::Vector3d p = r.result.trajectory.evaluate(t);
            return py::make_tuple(p.x(), p.y(), p.z());
          },
          py::arg("t"), "The trajectory's position (x, y, z) at time `t`, seconds from its start")
      .def("__repr__", [](const PyResult& r) {
        return "Result(status='" + std::string(toString(r.result.status)) +
               "', cost=" + formatNumber(r.result.cost) +
               ", planning_time_ms=" + formatNumber(r.result.planning_time_ms) + ")";
      });
}

void bindScene(py::module_& m) {
  py::class_<view::Scene>(m, "Scene")
      .def(py::init<const std::string&>())
      .def("set_world", [](view::Scene& s, const PyWorld& w) { s.setWorld(*w.world); })
      .def("add_query",
           [](view::Scene& s, const std::string& name, const py::object& start,
              const py::object& goal) {
             return s.addQuery(name, vector3(start, "start"), vector3(goal, "goal"));
           })
      .def("add_result",
           [](view::Scene& s, int query, const std::string& planner, const PyResult& r) {
             s.addTrajectory(query, planner, r.result.trajectory);
             if (r.has_tree) s.addTree(query, planner, r.tree);
           })
      .def("json", &view::Scene::json)
      .def("html", [](const view::Scene& s) { return view::viewHtml(s.json()); })
      .def("write", [](const view::Scene& s, const std::string& path) {
        view::writeViewHtml(path, s.json());
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
