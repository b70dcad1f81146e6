// kinolab._core's worlds: built or loaded from the cache, their grid and ESDF as read-only
// NumPy views, and distance queries over NumPy arrays (the GIL released).
#include <chrono>
#include <cmath>
#include <span>
#include <vector>

#include "bindings.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/world/world_cache.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab::python {
namespace {

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
  const double* values = array.data();
  for (py::ssize_t i = 0; i < array.size(); ++i) {
    if (!std::isfinite(values[i])) {
      throw InvalidArgument("points: row " + std::to_string(i / 3) + " is not finite");
    }
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

}  // namespace

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

}  // namespace kinolab::python
