// Test-only planners for the experiment runner (a plugin library, never built into kinolab):
// each misbehaves in one way, so the runner's isolation and the guards around plugin code can
// be tested (and a sensor and a vehicle map that throw). `test_trivial` does
// nothing at all (after an optional sleep): the runner's overhead per run. `test_metric`
// reports one statistic of its own, declared in one line, to show that it reaches every
// output without other edits (and, when told to, one it does not declare).
#include <chrono>
#include <csignal>
#include <stdexcept>
#include <thread>
#include <vector>

#include "kinolab/core/plugin.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/flight/vehicle_map.hpp"
#include "kinolab/planner/planner.hpp"

namespace {

using namespace kinolab;

enum class Misbehaviour { kNone, kCrash, kHang, kAllocate, kThrow, kThrowInt };

class MisbehavingPlanner final : public Planner {
 public:
  MisbehavingPlanner(Misbehaviour what, const ParameterSet& parameters)
      : what_(what), sleep_ms_(parameters.real("sleep_ms")) {}

 protected:
  void doSetup(const PlannerContext&) override {}
  PlanResult doPlan(const PlanningQuery&, StopCondition&) override {
    if (sleep_ms_ > 0.0) {
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(sleep_ms_));
    }
    switch (what_) {
      case Misbehaviour::kCrash:
        std::raise(SIGSEGV);
        break;
      case Misbehaviour::kHang:
        for (;;) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      case Misbehaviour::kAllocate: {
        std::vector<std::vector<char>> blocks;
        for (;;) blocks.emplace_back(std::size_t{64} << 20, 'x');
      }
      case Misbehaviour::kThrow:
        throw std::runtime_error("test_throw always throws");
      case Misbehaviour::kThrowInt:
        throw 42;  // not a std::exception
      case Misbehaviour::kNone:
        break;
    }
    PlanResult result;
    result.status = PlanStatus::kNoSolution;
    result.message = "test_trivial plans nothing";
    result.statistics = {{"sleep_ms", sleep_ms_}};
    return result;
  }
  PlannerLimits plannerLimits() const override { return {}; }

 private:
  Misbehaviour what_;
  double sleep_ms_;
};

/// Reports `probe_answer` (declared) and, with `undeclared`, `probe_undeclared` (not).
class MetricPlanner final : public Planner {
 public:
  explicit MetricPlanner(const ParameterSet& parameters)
      : undeclared_(parameters.boolean("undeclared")) {}

 protected:
  void doSetup(const PlannerContext&) override {}
  PlanResult doPlan(const PlanningQuery&, StopCondition&) override {
    PlanResult result;
    result.message = "test_metric plans nothing";
    result.statistics.emplace_back("probe_answer", 42.0);
    if (undeclared_) result.statistics.emplace_back("probe_undeclared", 1.0);
    return result;
  }
  PlannerLimits plannerLimits() const override { return {}; }

 private:
  bool undeclared_;
};

/// A camera whose rays cannot be had: rayDirections() throws a std::exception.
class ThrowingSensor final : public Sensor {
 public:
  double maxRange() const override { return 5.0; }
  double frameRate() const override { return 10.0; }
  std::vector<Eigen::Vector3d> rayDirections() const override {
    throw std::runtime_error("test_sensor_throws has no rays");
  }
};

/// A map whose sensor model throws an int on the first frame.
class ThrowingMap final : public VehicleMap {
 protected:
  void doInsert(const SensorFrame&, double) override { throw 13; }
};

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  const auto add = [&](const char* key, const char* doc, Misbehaviour what) {
    registrar.add<Planner>(
        key, doc, ParameterSpecs().real("sleep_ms", 0.0, 0.0, 1e6, "sleep this long first, ms"),
        [what](const ParameterSet& parameters) {
          return std::make_unique<MisbehavingPlanner>(what, parameters);
        },
        MetricSpecs().clock("sleep_ms", "how long it slept"));
  };
  add("test_trivial", "does nothing: no_solution at once (runner overhead)", Misbehaviour::kNone);
  add("test_crash", "dies of SIGSEGV", Misbehaviour::kCrash);
  add("test_hang", "never returns, ignoring its budget", Misbehaviour::kHang);
  add("test_oom", "allocates without bound", Misbehaviour::kAllocate);
  add("test_throw", "throws an exception", Misbehaviour::kThrow);
  add("test_throw_int", "throws an int (not a std::exception)", Misbehaviour::kThrowInt);
  // Factories that throw: a std::exception, and something that is not one.
  registrar.add<Planner>("test_factory_throws", "its factory throws an exception", ParameterSpecs(),
                         [](const ParameterSet&) -> std::unique_ptr<Planner> {
                           throw std::logic_error("test_factory_throws's factory always throws");
                         });
  registrar.add<Planner>("test_factory_throws_int", "its factory throws an int", ParameterSpecs(),
                         [](const ParameterSet&) -> std::unique_ptr<Planner> { throw 7; });
  registrar.add<Sensor>("test_sensor_throws", "its rays throw an exception", ParameterSpecs(),
                        [](const ParameterSet&) { return std::make_unique<ThrowingSensor>(); });
  registrar.add<VehicleMap>("test_map_throws_int", "inserting a frame throws an int",
                            ParameterSpecs(),
                            [](const ParameterSet&) { return std::make_unique<ThrowingMap>(); });
  registrar.add<Planner>(
      "test_metric", "reports a statistic of its own (and, if told, an undeclared one)",
      ParameterSpecs().boolean("undeclared", false, "also report an undeclared statistic"),
      [](const ParameterSet& parameters) { return std::make_unique<MetricPlanner>(parameters); },
      MetricSpecs().counter("probe_answer", "the answer this test planner always reports"));
}
