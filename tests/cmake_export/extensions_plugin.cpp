// A researcher's own extensions, built outside the kinolab tree against an installed kinolab
// (docs/extending/): one library adding a lazy lower bound, a heuristic and a flight sensor.
// No file under framework/ knows them or their parameters; every planner and flight chooses
// them by key (`lower_bound=scaled_endpoint`, `heuristic=scaled_time_optimal`,
// `sensor=ring`) and sets their parameters as `NAME.PARAMETER`.
#include <cmath>

#include "kinolab/core/plugin.hpp"
#include "kinolab/flight/sensor.hpp"
#include "kinolab/search/motion_primitive_planner.hpp"

namespace {

using namespace kinolab;

/// The paper's endpoint bound scaled by `scale` in [0, 1]. Any scale keeps it a lower bound of
/// the full cost (the endpoint bound is one, and every cost term is non-negative), so the
/// search stays optimal and returns eager's cost; a smaller scale defers more work to pop time.
class ScaledEndpointBound final : public EdgeEvaluationPolicy {
 public:
  explicit ScaledEndpointBound(double scale) : scale_(scale) {}

  EdgeEstimate evaluate(const EdgeEvaluator& evaluator, const ChainState& parent, double,
                        const Eigen::Vector3d& control, EdgeEvaluation& evaluation) const override {
    evaluation = evaluator.partial(parent, control);
    if (evaluation.valid()) evaluation.cost *= scale_;
    return EdgeEstimate::kLowerBound;
  }

 private:
  double scale_;
};

/// time_optimal scaled by `scale` in [0, 1]: still consistent (s h(a) <= s c + s h(b) <=
/// c + s h(b)), so still optimal, with more expansions the smaller the scale.
class ScaledTimeOptimal final : public SearchHeuristic {
 public:
  ScaledTimeOptimal(const HeuristicContext& context, double scale)
      : inner_(context.edges, context.goal_radius), scale_(scale) {}
  double estimate(const ChainState& state, const Eigen::Vector3d& goal) const override {
    return scale_ * inner_.estimate(state, goal);
  }

 private:
  TimeOptimalHeuristic inner_;
  double scale_;
};

/// One horizontal ring of `beams` rays around the vehicle: a planar scanner.
struct RingSensor final : Sensor {
  double range = 4.0;
  double rate = 10.0;
  int beams = 64;

  double maxRange() const override { return range; }
  double frameRate() const override { return rate; }
  std::vector<Eigen::Vector3d> rayDirections() const override {
    std::vector<Eigen::Vector3d> rays;
    for (int beam = 0; beam < beams; ++beam) {
      const double azimuth = 2.0 * M_PI * beam / beams;
      rays.emplace_back(std::cos(azimuth), std::sin(azimuth), 0.0);
    }
    return rays;
  }
};

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<EdgeEvaluationPolicy>(
      "scaled_endpoint", "the endpoint bound scaled down (a lazy planner's lower_bound)",
      ParameterSpecs().real("scale", 0.5, 0.0, 1.0, "share of the endpoint bound queued"),
      [](const ParameterSet& parameters) {
        return std::make_unique<ScaledEndpointBound>(parameters.real("scale"));
      });
  registrar.add<HeuristicBuilder>(
      "scaled_time_optimal", "time_optimal scaled down (consistent for any scale <= 1)",
      ParameterSpecs().real("scale", 0.5, 0.0, 1.0, "factor on time_optimal"),
      [](const ParameterSet& parameters) {
        const double scale = parameters.real("scale");
        return std::make_unique<HeuristicBuilder>([scale](const HeuristicContext& context) {
          return std::make_shared<ScaledTimeOptimal>(context, scale);
        });
      });
  const RingSensor ring;
  registrar.add<Sensor>("ring", "one horizontal ring of beams (a planar scanner)",
                        ParameterSpecs()
                            .real("range", ring.range, 0.1, 100.0, "m")
                            .real("rate", ring.rate, 0.5, 100.0, "frames per second")
                            .integer("beams", ring.beams, 4, 100000, "rays around"),
                        [](const ParameterSet& parameters) {
                          auto sensor = std::make_unique<RingSensor>();
                          sensor->range = parameters.real("range");
                          sensor->rate = parameters.real("rate");
                          sensor->beams = static_cast<int>(parameters.integer("beams"));
                          return sensor;
                        });
}
