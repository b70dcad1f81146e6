#include "kinolab/experiment/sampling_study.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/core/yaml_fields.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {
namespace {

/// A list item's number, in [low, high].
double numberIn(const YamlReader& item, double low, double high) {
  const double value = item.as<double>();
  if (!(value >= low && value <= high)) {
    item.fail("expected a number in [" + formatNumber(low) + ", " + formatNumber(high) + "], got " +
              formatNumber(value));
  }
  return value;
}

/// A list of `first` or `second` names, as whether each is `second`.
std::vector<bool> twoChoices(const YamlReader& list, const std::string& first,
                             const std::string& second) {
  std::vector<bool> chosen;
  for (const YamlReader& item : list.items()) {
    const std::string name = item.as<std::string>();
    if (name != first && name != second) {
      item.fail("expected " + first + " or " + second + ", got '" + name + "'");
    }
    chosen.push_back(name == second);
  }
  return chosen;
}

/// alpha's numerator (distances above the threshold) and L (their mean; NaN for a set of
/// one) from the nearest-neighbour distances of a set.
void spreadOf(const std::vector<double>& nearest, double threshold, int* useful,
              double* mean_nearest) {
  *useful = 0;
  double sum = 0.0;
  for (const double d : nearest) {
    *useful += d > threshold ? 1 : 0;
    sum += d;
  }
  *mean_nearest = nearest.size() > 1 ? sum / static_cast<double>(nearest.size()) : NAN;
}

}  // namespace

namespace {

/// The checks across fields of `dynamics:` and `states:`, and the limits on every axis.
void checkDynamicsAndStates(const YamlReader& root, SamplingStudyConfig& config) {
  const SamplingStudyConfig::Dynamics::Limits& limits = config.dynamics.limits;
  const std::pair<const char*, double> bounds[] = {{"velocity", limits.velocity},
                                                   {"acceleration", limits.acceleration},
                                                   {"jerk", limits.jerk},
                                                   {"snap", limits.snap}};
  // Every derivative below the control needs a bound, and so does the control itself.
  for (int k = 1; k <= config.dynamics.order; ++k) {
    const auto& [name, value] = bounds[k - 1];
    if (std::isinf(value)) {
      root["dynamics"]["limits"].fail("missing required key '" + std::string(name) +
                                      "' (order " + std::to_string(config.dynamics.order) +
                                      " limits every derivative up to the control)");
    }
  }
  config.limits =
      DynamicLimits::uniform(limits.velocity, limits.acceleration, limits.jerk, limits.snap);
  const SamplingStudyConfig::States& states = config.states;
  const YamlReader at = root.optional("states").value_or(root);  // the defaults: the file
  if (!states.rest && states.moving == 0) at.fail("no initial states");
  if (states.speed[1] > config.limits.bound[1].x()) {
    const auto speed = at.optional("speed");
    (speed ? *speed : at)
        .fail("initial speeds must not exceed the velocity limit " +
              std::to_string(config.limits.bound[1].x()) +
              (speed ? std::string() : " (the default speeds: 0.5 to 2 m/s; set states.speed)"));
  }
}

/// `samplers: [{type, id, params, paper: {alpha, L}}, ...]`.
void readSamplers(const YamlReader& root, SamplingStudyConfig& config) {
  using Sampler = SamplingStudyConfig::Sampler;
  const auto& registry = pluginRegistry<ControlSampler>();
  for (const YamlReader& item : root["samplers"].items()) {
    Sampler sampler;
    sampler.type = item.get<std::string>("type");
    sampler.id = item.get<std::string>("id", sampler.type);
    for (const auto& other : config.samplers) {
      if (other.id == sampler.id) item["id"].fail("duplicate sampler id '" + sampler.id + "'");
    }
    try {
      const auto params = item.optional("params");
      if (params) sampler.assignments = assignmentsFromYaml(*params);
      sampler.parameters = registry.resolve(sampler.type, sampler.assignments);
    } catch (const PluginError& error) {
      item["type"].fail(error.what());
    }
    if (const auto paper = item.optional("paper")) {
      if (paper->optional("alpha")) sampler.paper_alpha = paper->getNumber("alpha", {}, 0.0, 1.0);
      if (paper->optional("L")) sampler.paper_l = paper->getNumber("L", {}, 0.0, 1e6);
      paper->finish();
    }
    item.finish();
    config.samplers.push_back(std::move(sampler));
  }
  if (config.samplers.empty()) root["samplers"].fail("expected at least one sampler");
}

/// `readings: {thresholds, distance, propagation, pooling, samples_per_axis}`.
void readReadings(const YamlReader& readings, SamplingStudyConfig& config) {
  SamplingStudyConfig::Readings& r = config.readings;
  for (const YamlReader& item : readings["thresholds"].items()) {
    r.thresholds.push_back(numberIn(item, 1e-9, 100.0));
  }
  r.with_velocity = twoChoices(readings["distance"], "position", "position_velocity");
  for (const bool euler : twoChoices(readings["propagation"], "exact", "euler")) {
    r.propagations.push_back(euler ? Propagation::kEuler : Propagation::kExact);
  }
  r.pooled = twoChoices(readings["pooling"], "per_state", "pooled");
  for (const YamlReader& item : readings["samples_per_axis"].items()) {
    const double per_axis = numberIn(item, 1, 9);
    if (per_axis != std::floor(per_axis)) item.fail("expected an integer from 1 to 9");
    r.samples_per_axis.push_back(static_cast<int>(per_axis));
  }
  for (const char* key : {"thresholds", "distance", "propagation", "pooling", "samples_per_axis"}) {
    if (readings[key].items().empty()) readings[key].fail("expected at least one value");
  }
  readings.finish();
  // Every sampler must take the M of the readings.
  const auto& registry = pluginRegistry<ControlSampler>();
  for (const SamplingStudyConfig::Sampler& sampler : config.samplers) {
    if (!registry.info(sampler.type).parameters.find("samples_per_axis")) {
      readings["samples_per_axis"].fail("sampler '" + sampler.id +
                                        "' has no samples_per_axis parameter");
    }
  }
}

}  // namespace

SamplingStudyConfig SamplingStudyConfig::fromFile(const std::string& path) {
  const YamlReader root = YamlReader::loadFile(path);
  SamplingStudyConfig config;
  config.source = path;
  const std::string kind = root.get<std::string>("kind");
  if (kind != "sampling_study") {
    root["kind"].fail("expected 'sampling_study' (this command runs sampling studies), got '" +
                      kind + "'");
  }
  readYamlFields(root, config);
  checkDynamicsAndStates(root, config);
  readSamplers(root, config);
  if (const auto readings = root.optional("readings")) readReadings(*readings, config);
  root.finish();
  return config;
}

std::vector<ChainState> samplingStudyStates(const SamplingStudyConfig& config) {
  std::vector<ChainState> states;
  if (config.states.rest) states.push_back(ChainState::Zero());
  Rng rng = Rng::derive(config.seed, "sampling_study_states");
  for (int i = 0; i < config.states.moving; ++i) {
    ChainState state = ChainState::Zero();
    // A uniformly random direction (normalised Gaussian) at a uniformly random speed.
    auto direction = drawLastFirst<Eigen::Vector3d>([&](int) { return rng.normal(); });
    direction.normalize();
    state.col(1) = direction * rng.uniform(config.states.speed[0], config.states.speed[1]);
    // Derivatives between velocity and the control: within half their limit.
    for (int k = 2; k < config.dynamics.order; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        const double half = 0.5 * config.limits.bound[k][axis];
        state(axis, k) = rng.uniform(-half, half);
      }
    }
    states.push_back(state);
  }
  return states;
}

namespace {

/// An exact k-d tree over a fixed set of points (their first `dims` coordinates): each node
/// is a range of the index order split at its median on the axis of widest spread, so that
/// one nearest-other-point query costs O(log n) expected instead of the O(n) of a scan (the
/// scan made 64^3 samples a state take hours).
class NearestOther {
 public:
  using Point = Eigen::Matrix<double, 6, 1>;

  NearestOther(const std::vector<Point>& points, int dims)
      : points_(points), dims_(dims), order_(points.size()), axis_(points.size(), 0) {
    std::iota(order_.begin(), order_.end(), std::size_t{0});
    build(0, order_.size());
  }

  /// The squared distance from point i to the nearest other point (INFINITY when alone).
  double squared(std::size_t i) const {
    double best = INFINITY;
    search(0, order_.size(), i, best);
    return best;
  }

 private:
  static constexpr std::size_t kLeaf = 8;

  double distance2(std::size_t a, std::size_t b) const {
    return (points_[a] - points_[b]).head(dims_).squaredNorm();
  }

  void build(std::size_t lo, std::size_t hi) {
    if (hi - lo <= kLeaf) return;
    Point low = Point::Constant(INFINITY);
    Point high = Point::Constant(-INFINITY);
    for (std::size_t k = lo; k < hi; ++k) {
      low = low.cwiseMin(points_[order_[k]]);
      high = high.cwiseMax(points_[order_[k]]);
    }
    int axis = 0;
    (high - low).head(dims_).maxCoeff(&axis);
    const std::size_t mid = lo + (hi - lo) / 2;
    std::nth_element(
        order_.begin() + static_cast<std::ptrdiff_t>(lo),
        order_.begin() + static_cast<std::ptrdiff_t>(mid),
        order_.begin() + static_cast<std::ptrdiff_t>(hi),
        [&](std::size_t a, std::size_t b) { return points_[a][axis] < points_[b][axis]; });
    axis_[mid] = axis;
    build(lo, mid);
    build(mid + 1, hi);
  }

  // Before `mid` nothing lies above the median on its axis, after it nothing below: the far
  // side is searched only when the splitting plane is nearer than the best found.
  void search(std::size_t lo, std::size_t hi, std::size_t i, double& best) const {
    if (hi - lo <= kLeaf) {
      for (std::size_t k = lo; k < hi; ++k) {
        if (order_[k] != i) best = std::min(best, distance2(i, order_[k]));
      }
      return;
    }
    const std::size_t mid = lo + (hi - lo) / 2;
    const std::size_t median = order_[mid];
    if (median != i) best = std::min(best, distance2(i, median));
    const double gap = points_[i][axis_[mid]] - points_[median][axis_[mid]];
    if (gap < 0.0) {
      search(lo, mid, i, best);
      if (gap * gap < best) search(mid + 1, hi, i, best);
    } else {
      search(mid + 1, hi, i, best);
      if (gap * gap < best) search(lo, mid, i, best);
    }
  }

  const std::vector<Point>& points_;
  int dims_;
  std::vector<std::size_t> order_;
  std::vector<int> axis_;  // at each node's median: its splitting axis
};

}  // namespace

std::vector<double> nearestDistances(const std::vector<Eigen::Matrix<double, 6, 1>>& points,
                                     int dims) {
  const NearestOther tree(points, dims);
  std::vector<double> nearest(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) nearest[i] = std::sqrt(tree.squared(i));
  return nearest;
}

std::vector<SamplingReadingRow> runSamplingReadings(const SamplingStudyConfig& config) {
  const SamplingStudyConfig::Readings& readings = config.readings;
  std::vector<SamplingReadingRow> rows;
  if (readings.thresholds.empty()) return rows;
  const std::vector<ChainState> states = samplingStudyStates(config);
  const Eigen::Vector3d u_max = config.limits.bound[config.dynamics.order];
  const auto& registry = pluginRegistry<ControlSampler>();
  for (const auto& entry : config.samplers) {
    const std::uint64_t seed = Rng::derive(config.seed, "sampler:" + entry.id).nextU64();
    for (const int per_axis : readings.samples_per_axis) {
      std::vector<ParameterAssignment> assignments = entry.assignments;
      assignments.push_back({"samples_per_axis", std::to_string(per_axis), "readings"});
      const auto sampler =
          registry.createResolved(entry.type, registry.resolve(entry.type, assignments));
      const std::vector<Eigen::Vector3d> controls = sampler->sample(u_max, seed);
      for (const Propagation propagation : readings.propagations) {
        const IntegratorChain chain(config.dynamics.order, propagation, config.dynamics.euler_steps);
        // Displacements (position, velocity) of every primitive from every state.
        std::vector<std::vector<Eigen::Matrix<double, 6, 1>>> per_state;
        for (const ChainState& state : states) {
          auto& ends = per_state.emplace_back();
          for (const auto& control : controls) {
            const ChainState end = chain.propagate(state, control, config.dynamics.duration);
            Eigen::Matrix<double, 6, 1> point;
            point << end.col(0) - state.col(0), end.col(1) - state.col(1);
            ends.push_back(point);
          }
        }
        for (const bool with_velocity : readings.with_velocity) {
          const int dims = with_velocity ? 6 : 3;
          for (const bool pooled : readings.pooled) {
            // Sets of points: one per state, or all of them at once.
            std::vector<std::vector<double>> nearest;
            if (pooled) {
              std::vector<Eigen::Matrix<double, 6, 1>> all;
              for (const auto& ends : per_state) all.insert(all.end(), ends.begin(), ends.end());
              nearest.push_back(nearestDistances(all, dims));
            } else {
              for (const auto& ends : per_state) nearest.push_back(nearestDistances(ends, dims));
            }
            for (const double threshold : readings.thresholds) {
              SamplingReadingRow row;
              row.sampler = entry.id;
              row.controls = static_cast<int>(controls.size());
              row.with_velocity = with_velocity;
              row.propagation = propagation;
              row.pooled = pooled;
              row.threshold = threshold;
              int finite_sets = 0;
              for (const auto& set : nearest) {
                int useful = 0;
                double mean = NAN;
                spreadOf(set, threshold, &useful, &mean);
                row.alpha += static_cast<double>(useful) / static_cast<double>(set.size());
                if (!std::isnan(mean)) {
                  row.mean_nearest += mean;
                  ++finite_sets;
                }
              }
              row.alpha /= static_cast<double>(nearest.size());
              row.mean_nearest = finite_sets ? row.mean_nearest / finite_sets : NAN;
              rows.push_back(row);
            }
          }
        }
      }
    }
  }
  return rows;
}

void endpointSpread(const std::vector<Eigen::Vector3d>& endpoints, double threshold, int* useful,
                    double* mean_nearest) {
  std::vector<Eigen::Matrix<double, 6, 1>> points;
  points.reserve(endpoints.size());
  for (const Eigen::Vector3d& p : endpoints) {
    points.emplace_back();
    points.back() << p, Eigen::Vector3d::Zero();
  }
  spreadOf(nearestDistances(points, 3), threshold, useful, mean_nearest);
}

std::vector<SamplingStudyRow> runSamplingStudy(const SamplingStudyConfig& config) {
  const IntegratorChain chain(config.dynamics.order, config.dynamics.propagation, config.dynamics.euler_steps);
  const std::vector<ChainState> states = samplingStudyStates(config);
  const Eigen::Vector3d u_max = config.limits.bound[config.dynamics.order];
  std::vector<SamplingStudyRow> rows;
  for (const auto& entry : config.samplers) {
    const auto sampler =
        pluginRegistry<ControlSampler>().createResolved(entry.type, entry.parameters);
    // Each sampler its own stream, so adding one never changes another's controls.
    const std::uint64_t seed = Rng::derive(config.seed, "sampler:" + entry.id).nextU64();
    const std::vector<Eigen::Vector3d> controls = sampler->sample(u_max, seed);
    for (std::size_t s = 0; s < states.size(); ++s) {
      SamplingStudyRow row;
      row.sampler = entry.id;
      row.state = static_cast<int>(s);
      row.speed = states[s].col(1).norm();
      row.controls = static_cast<int>(controls.size());
      std::vector<Eigen::Vector3d> endpoints;
      std::vector<bool> feasible;
      for (const auto& control : controls) {
        endpoints.push_back(chain.propagate(states[s], control, config.dynamics.duration).col(0));
        feasible.push_back(chain.withinLimits(states[s], control, config.dynamics.duration, config.limits));
        row.limit_breaking += feasible.back() ? 0 : 1;
      }
      double mean_nearest = 0.0;
      endpointSpread(endpoints, config.threshold, &row.useful, &mean_nearest);
      row.mean_nearest = mean_nearest;
      // Useful among the feasible ones: the same test over the feasible endpoints only.
      std::vector<Eigen::Vector3d> feasible_endpoints;
      for (std::size_t i = 0; i < endpoints.size(); ++i) {
        if (feasible[i]) feasible_endpoints.push_back(endpoints[i]);
      }
      double unused = 0.0;
      endpointSpread(feasible_endpoints, config.threshold, &row.useful_feasible, &unused);
      row.alpha = static_cast<double>(row.useful) / row.controls;
      rows.push_back(row);
    }
  }
  return rows;
}

std::vector<SamplingStudySummary> summarizeSamplingStudy(
    const SamplingStudyConfig& config, const std::vector<SamplingStudyRow>& rows) {
  std::vector<SamplingStudySummary> result;
  for (const auto& entry : config.samplers) {
    SamplingStudySummary summary;
    summary.sampler = entry.id;
    summary.type = entry.type;
    summary.paper_alpha = entry.paper_alpha;
    summary.paper_l = entry.paper_l;
    double alpha2 = 0.0;
    double l2 = 0.0;
    int count = 0;
    int breaking = 0;
    int useful_feasible = 0;
    for (const auto& row : rows) {
      if (row.sampler != entry.id) continue;
      summary.controls = row.controls;
      summary.alpha += row.alpha;
      alpha2 += row.alpha * row.alpha;
      summary.mean_nearest += row.mean_nearest;
      l2 += row.mean_nearest * row.mean_nearest;
      breaking += row.limit_breaking;
      useful_feasible += row.useful_feasible;
      ++count;
    }
    if (count == 0) continue;
    const auto sd = [count](double sum, double squares) {
      const double mean = sum / count;
      return count > 1 ? std::sqrt(std::max(0.0, (squares - count * mean * mean) / (count - 1)))
                       : 0.0;
    };
    summary.alpha_sd = sd(summary.alpha, alpha2);
    summary.mean_nearest_sd = sd(summary.mean_nearest, l2);
    summary.alpha /= count;
    summary.mean_nearest /= count;
    const double primitives = static_cast<double>(count) * summary.controls;
    summary.limit_breaking_share = breaking / primitives;
    summary.alpha_feasible = useful_feasible / primitives;
    result.push_back(summary);
  }
  return result;
}

}  // namespace kinolab
