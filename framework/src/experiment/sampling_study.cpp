#include "kinolab/experiment/sampling_study.hpp"

#include <cmath>
#include <limits>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"
#include "kinolab/core/yaml_reader.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {

SamplingStudyConfig SamplingStudyConfig::fromFile(const std::string& path) {
  const YamlReader root = YamlReader::loadFile(path);
  SamplingStudyConfig config;
  config.source = path;
  const std::string kind = root.get<std::string>("kind");
  if (kind != "sampling_study") {
    root["kind"].fail("expected 'sampling_study' (this command runs sampling studies), got '" +
                      kind + "'");
  }
  config.name = root.get<std::string>("name");
  config.seed = static_cast<std::uint64_t>(
      root.getInteger("seed", 1, 0, std::numeric_limits<long long>::max()));
  config.threshold = root.getNumber("threshold", 0.1, 1e-9, 100.0);

  const YamlReader dynamics = root["dynamics"];
  config.order = static_cast<int>(dynamics.getInteger("order", 2, 2, 4));
  config.duration = dynamics.getNumber("duration", std::nullopt, 1e-6, 100.0);
  const std::string propagation = dynamics.get<std::string>("propagation", "exact");
  if (propagation == "euler") {
    config.propagation = Propagation::kEuler;
  } else if (propagation != "exact") {
    dynamics["propagation"].fail("expected exact or euler, got '" + propagation + "'");
  }
  config.euler_steps = static_cast<int>(dynamics.getInteger("euler_steps", 1, 1, 10000));
  const YamlReader limits = dynamics["limits"];
  const char* names[] = {"", "velocity", "acceleration", "jerk", "snap"};
  for (int k = 1; k <= 4; ++k) {
    // Every derivative below the control needs a bound, and so does the control itself.
    const bool required = k <= config.order;
    const auto value = required ? limits.getNumber(names[k], std::nullopt, 1e-9, 1e9)
                                : limits.getNumber(names[k], INFINITY, 1e-9, INFINITY);
    config.limits.bound[k].setConstant(value);
  }
  limits.finish();
  dynamics.finish();

  // An absent `states:` means the defaults; an empty mapping reads the same way.
  const YamlReader states = root.optional("states").value_or(
      YamlReader::loadString("{}", config.source + " (default states)"));
  config.rest_state = states.get<bool>("rest", true);
  config.moving_states = static_cast<int>(states.getInteger("moving", 20, 0, 100000));
  const auto speed = states.getInterval("speed", std::array<double, 2>{0.5, 2.0}, 0.0, 1e6);
  config.min_speed = speed[0];
  config.max_speed = speed[1];
  states.finish();
  if (!config.rest_state && config.moving_states == 0) states.fail("no initial states");
  if (config.max_speed > config.limits.bound[1].x()) {
    states["speed"].fail("initial speeds must not exceed the velocity limit " +
                         std::to_string(config.limits.bound[1].x()));
  }

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
      sampler.parameters = registry.resolve(
          sampler.type, params ? assignmentsFromYaml(*params) : std::vector<ParameterAssignment>{});
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
  root.finish();
  return config;
}

std::vector<ChainState> samplingStudyStates(const SamplingStudyConfig& config) {
  std::vector<ChainState> states;
  if (config.rest_state) states.push_back(ChainState::Zero());
  Rng rng = Rng::derive(config.seed, "sampling_study_states");
  for (int i = 0; i < config.moving_states; ++i) {
    ChainState state = ChainState::Zero();
    // A uniformly random direction (normalised Gaussian) at a uniformly random speed.
    Eigen::Vector3d direction(rng.normal(), rng.normal(), rng.normal());
    direction.normalize();
    state.col(1) = direction * rng.uniform(config.min_speed, config.max_speed);
    // Derivatives between velocity and the control: within half their limit.
    for (int k = 2; k < config.order; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        const double half = 0.5 * config.limits.bound[k][axis];
        state(axis, k) = rng.uniform(-half, half);
      }
    }
    states.push_back(state);
  }
  return states;
}

void endpointSpread(const std::vector<Eigen::Vector3d>& endpoints, double threshold, int* useful,
                    double* mean_nearest) {
  const std::size_t count = endpoints.size();
  *useful = 0;
  double sum = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    double nearest = INFINITY;
    for (std::size_t j = 0; j < count; ++j) {
      if (j != i) nearest = std::min(nearest, (endpoints[i] - endpoints[j]).norm());
    }
    if (nearest > threshold) ++*useful;
    sum += nearest;
  }
  *mean_nearest = count > 1 ? sum / static_cast<double>(count) : NAN;
}

std::vector<SamplingStudyRow> runSamplingStudy(const SamplingStudyConfig& config) {
  const IntegratorChain chain(config.order, config.propagation, config.euler_steps);
  const std::vector<ChainState> states = samplingStudyStates(config);
  const Eigen::Vector3d u_max = config.limits.bound[config.order];
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
        endpoints.push_back(chain.propagate(states[s], control, config.duration).col(0));
        feasible.push_back(chain.withinLimits(states[s], control, config.duration, config.limits));
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
