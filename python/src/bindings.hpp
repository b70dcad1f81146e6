// kinolab._core's parts (see module.cpp): the world and planner objects they share, the
// conversions more than one part uses, and the function that binds each part.
#pragma once

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <mutex>
#include <string>

#include "kinolab/core/parameters.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world.hpp"

namespace kinolab::python {

namespace py = pybind11;

/// A built world and how it was obtained (built, or loaded from the cache).
struct PyWorld {
  std::shared_ptr<const World> world;
  std::string source = "built";
  double seconds = 0.0;
  std::string cache_file;
};

/// A configured planner, set up on one world.
struct PyPlanner {
  ConfiguredPlanner configured;
  std::shared_ptr<const World> world;
  /// Held (with the GIL released) by setup, reset and plan: a Planner shared by threads
  /// serves one call at a time, never two on the same search state.
  std::unique_ptr<std::mutex> busy = std::make_unique<std::mutex>();
};

/// Three finite numbers (a point or a vector), named `name` in errors.
Eigen::Vector3d vector3(const py::object& value, const std::string& name);

/// A start state: the position, and the velocity and acceleration when given (else zero).
ChainState startState(const py::object& position, const py::object& velocity,
                      const py::object& acceleration);

/// A parameter's value as the Python object of its type.
py::object parameterValue(const ParameterValue& value);

/// World, world_from_file, world_from_text and default_cache_dir (world_bindings.cpp).
void bindWorld(py::module_& m);
/// plugins, plugin_kinds, load_plugin and metrics (plugin_bindings.cpp).
void bindPlugins(py::module_& m);
/// Planner and Assignment (planner_bindings.cpp).
void bindPlanner(py::module_& m);
/// Result: a plan's outcome, metrics, trajectory and tree (planner_bindings.cpp).
void bindResult(py::module_& m);
/// Scene: worlds, queries and results for the 3D viewer (planner_bindings.cpp).
void bindScene(py::module_& m);

}  // namespace kinolab::python
