// `bspline`: the TGK analogue's back end as a back end of any planner. The front end's path
// becomes a uniform cubic B-spline optimised with Ceres (jerk, an ESDF obstacle penalty with
// its analytic gradient, velocity and acceleration penalties), then its time is re-allocated
// until the limits hold; after a collision it starts again, denser and heavier
// (bspline_smoother.hpp; docs/back_ends/bspline.md).
#include <optional>

#include "bspline_smoother.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/planner/back_end.hpp"

namespace kinolab::smoothing {
namespace {

class BsplineBackEnd final : public BackEnd {
 public:
  explicit BsplineBackEnd(const ParameterSet& parameters)
      : settings_(readFields<SmootherSettings>(parameters)) {}

  void setup(std::shared_ptr<const World> world, const Body& body,
             const PlannerLimits& limits) override {
    SmootherSettings settings = settings_;
    const double safety = settings.body.safety_band;  // its own `safety_distance`
    settings.body = body;
    settings.body.safety_band = safety;
    settings.limits = limits.limits;
    smoother_.emplace(std::move(world), settings);
  }

  BackEndResult refine(const BackEndProblem& problem, StopCondition& stop) const override {
    if (!smoother_) throw InvalidArgument("bspline: refine() before setup()");
    BackEndResult result;
    result.failure = backEndInputProblem(problem);
    if (result.failure.empty() && problem.path.size() < 2) {
      result.failure = "a path of fewer than two points";
    }
    if (!result.failure.empty()) return result;
    SmootherResult smoothed = smoother_->smooth(problem.start, problem.path, stop);
    result.statistics = std::move(smoothed.statistics);
    if (smoothed.valid) {
      result.trajectory = std::move(smoothed.trajectory);
    } else {
      result.failure = smoothed.problem.empty() ? "no valid spline" : smoothed.problem;
    }
    return result;
  }

  double budgetShare() const override { return settings_.budget_share; }

 private:
  SmootherSettings settings_;
  std::optional<BsplineSmoother> smoother_;
};

}  // namespace
}  // namespace kinolab::smoothing

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.library("ceres", smoothing::ceresVersion());
  registrar.add<BackEnd>(
      "bspline",
      "Ceres uniform cubic B-spline (the TGK analogue's): jerk, ESDF clearance, limits, time "
      "re-allocation",
      declareFields<smoothing::SmootherSettings>(),
      [](const ParameterSet& parameters) {
        return std::make_unique<smoothing::BsplineBackEnd>(parameters);
      },
      smoothing::smootherStatistics());
}
