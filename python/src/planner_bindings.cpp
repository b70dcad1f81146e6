// kinolab._core's planners and their results: configuring and setting up a planner, planning
// (the GIL released), a result's status, metrics, trajectory and search tree as Python and
// NumPy objects, and a 3D scene of results for the viewer.
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/primitives/control_sampler.hpp"
#include "kinolab/view/scene.hpp"

namespace kinolab::python {

Eigen::Vector3d vector3(const py::object& value, const std::string& name) {
  const auto array = py::array_t<double, py::array::forcecast>::ensure(value);
  if (!array || array.size() != 3) throw InvalidArgument(name + ": expected three numbers x, y, z");
  const Eigen::Vector3d vector(array.data()[0], array.data()[1], array.data()[2]);
  if (!vector.allFinite()) throw InvalidArgument(name + ": not finite");
  return vector;
}

ChainState startState(const py::object& position, const py::object& velocity,
                      const py::object& acceleration) {
  ChainState state = ChainState::Zero();
  state.col(0) = vector3(position, "start");
  if (!velocity.is_none()) state.col(1) = vector3(velocity, "start_velocity");
  if (!acceleration.is_none()) state.col(2) = vector3(acceleration, "start_acceleration");
  return state;
}

namespace {

/// A planning result: the framework's PlanResult, the planner's declared statistics and the
/// search tree when one was asked for.
struct PyResult {
  PlanResult result;
  const PluginInfo* planner = nullptr;  ///< its registration: the statistics it declares
  SearchTree tree;
  bool has_tree = false;
};

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
    const std::lock_guard lock(*self.busy);
    out.result = self.configured.planner->plan(query, Budget{time_limit, max_iterations},
                                               tree ? &out.tree : nullptr);
  }
  out.has_tree = tree;
  return out;
}

py::dict trajectorySamples(const Trajectory& trajectory, double step) {
  if (!(step > 0.0 && std::isfinite(step))) {
    throw InvalidArgument("step: expected a finite positive number of seconds");
  }
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

}  // namespace

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
             const std::shared_ptr<const World> map = world.world;
             {
               py::gil_scoped_release release;
               const std::lock_guard lock(*p.busy);
               p.configured.planner->setup({map, seed});
             }
             p.world = map;  // with the GIL held, as plan() reads it
           })
      .def("reset",
           [](PyPlanner& p) {
             py::gil_scoped_release release;
             const std::lock_guard lock(*p.busy);
             p.configured.planner->reset();
           })
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
          "exact, approximate, no_solution, timeout, invalid_start, invalid_goal, "
          "invalid_trajectory or back_end_failed")
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

}  // namespace kinolab::python
