#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "kinolab/core/parameters.hpp"
#include "kinolab/dynamics/integrator_chain.hpp"

namespace kinolab {

/// The paper's Table I as an experiment: for each sampler, primitives from a set of
/// representative initial states (at rest, and moving in seeded random directions), and per
/// state the ratio alpha of useful samples (endpoint farther than `threshold` from every other
/// endpoint), the mean nearest-neighbour distance L of the endpoints, and the count of
/// primitives that break the dynamic limits.
struct SamplingStudyConfig {
  struct Sampler {
    std::string id;    ///< name in tables and CSV
    std::string type;  ///< registry key
    ParameterSet parameters;
    std::vector<ParameterAssignment> assignments;  ///< as written (readings re-resolve them)
    std::optional<double> paper_alpha;  ///< the paper's figure, for the side-by-side table
    std::optional<double> paper_l;
  };

  /// `dynamics:`: the integrator chain, the primitives' duration and a limit per derivative.
  struct Dynamics {
    /// `limits:`, the same on every axis; every derivative up to the order needs one (checked
    /// after the read: it depends on the order).
    struct Limits {
      double velocity = INFINITY;
      double acceleration = INFINITY;
      double jerk = INFINITY;
      double snap = INFINITY;
      template <typename Fields>
      void fields(Fields& f) {
        f.real("velocity", velocity, 1e-9, 1e9, "m/s");
        f.real("acceleration", acceleration, 1e-9, 1e9, "m/s^2");
        f.real("jerk", jerk, 1e-9, 1e9, "m/s^3");
        f.real("snap", snap, 1e-9, 1e9, "m/s^4");
      }
    };
    int order = 2;
    double duration = 0.4;
    Propagation propagation = Propagation::kExact;
    int euler_steps = 1;
    Limits limits;
    template <typename Fields>
    void fields(Fields& f) {
      f.integer("order", order, 2, 4, "2: acceleration, 3: jerk, 4: snap control");
      f.real("duration", duration, 1e-6, 100.0, "tau, s", {.required = true});
      f.choice("propagation", propagation,
               {{"exact", Propagation::kExact}, {"euler", Propagation::kEuler}},
               "closed form, or the paper's Euler step");
      f.integer("euler_steps", euler_steps, 1, 10000, "Euler steps over tau");
      f.group("limits", limits, "a limit per derivative, the same on every axis",
              {.required = true});
    }
  };
  /// `states: {rest, moving, speed}`.
  struct States {
    bool rest = true;
    int moving = 20;
    std::array<double, 2> speed = {0.5, 2.0};  ///< m/s
    template <typename Fields>
    void fields(Fields& f) {
      f.boolean("rest", rest, "include the state at rest");
      f.integer("moving", moving, 0, 100000, "moving states in seeded random directions");
      f.interval("speed", speed, 0.0, 1e6, "the moving states' speeds, m/s");
    }
  };

  std::string name;
  std::string source;  ///< the file it was read from
  std::uint64_t seed = 1;
  double threshold = 0.1;
  Dynamics dynamics;
  DynamicLimits limits;  ///< dynamics.limits on every axis
  States states;
  std::vector<Sampler> samplers;

  /// Table I under every reading (`readings:`, optional): each combination of the lists
  /// below, for every sampler. Empty lists: no readings.
  struct Readings {
    std::vector<double> thresholds;         ///< m (position) or the mixed norm (with velocity)
    std::vector<bool> with_velocity;        ///< distance over (p) or over (p, v)
    std::vector<Propagation> propagations;  ///< exact, or the paper's Euler step
    std::vector<bool> pooled;               ///< per state, or every state's displacements at once
    std::vector<int> samples_per_axis;      ///< M = this^3 (the samplers' own parameter)
  };
  Readings readings;

  /// The keys read from the field list (`samplers:` and `readings:` are read by hand).
  template <typename Fields>
  void fields(Fields& f) {
    f.text("name", name, "the study's name", {.required = true});
    f.integer("seed", seed, 0, std::numeric_limits<long long>::max(), "seed of the states");
    f.real("threshold", threshold, 1e-9, 100.0, "useful: no other endpoint this close, m");
    f.group("dynamics", dynamics, "the chain and its limits", {.required = true});
    f.group("states", states, "the initial states");
  }

  /// Reads and validates a `kind: sampling_study` file (unknown keys, types, ranges, sampler
  /// types and parameters are ConfigErrors with file, line and key path).
  static SamplingStudyConfig fromFile(const std::string& path);
};

/// One sampler from one initial state.
struct SamplingStudyRow {
  std::string sampler;
  int state = 0;              ///< index in the state list; 0 is rest when it is included
  double speed = 0.0;         ///< initial speed
  int controls = 0;           ///< M
  int useful = 0;             ///< samples whose endpoint has no other within the threshold
  int limit_breaking = 0;     ///< primitives that break a limit somewhere over tau
  int useful_feasible = 0;    ///< useful and within the limits
  double alpha = 0.0;         ///< useful / M
  double mean_nearest = 0.0;  ///< L, metres (NaN when M = 1)
};

/// Per-sampler means over the states.
struct SamplingStudySummary {
  std::string sampler;
  std::string type;
  int controls = 0;
  double alpha = 0.0;
  double alpha_sd = 0.0;
  double mean_nearest = 0.0;
  double mean_nearest_sd = 0.0;
  double limit_breaking_share = 0.0;  ///< of all primitives over all states
  double alpha_feasible = 0.0;
  std::optional<double> paper_alpha;
  std::optional<double> paper_l;
};

/// The initial states of the study (positions at the origin), seeded.
std::vector<ChainState> samplingStudyStates(const SamplingStudyConfig& config);

/// Runs every sampler from every state. Samplers are looked up in the registry.
std::vector<SamplingStudyRow> runSamplingStudy(const SamplingStudyConfig& config);

std::vector<SamplingStudySummary> summarizeSamplingStudy(const SamplingStudyConfig& config,
                                                         const std::vector<SamplingStudyRow>& rows);

/// One sampler under one reading of Table I: alpha at every threshold and L.
struct SamplingReadingRow {
  std::string sampler;
  int controls = 0;
  bool with_velocity = false;
  Propagation propagation = Propagation::kExact;
  bool pooled = false;
  double threshold = 0.0;
  double alpha = 0.0;
  double mean_nearest = 0.0;
};

/// Every sampler under every reading of `config.readings` (none when it is empty). Per
/// state: alpha and L of each state's endpoints, averaged over the states; pooled: one set
/// of the displacements (endpoint less start: position, and velocity with_velocity) from
/// every state. Distances are Euclidean over position (m) or over (position m, velocity m/s).
std::vector<SamplingReadingRow> runSamplingReadings(const SamplingStudyConfig& config);

/// The distance from each point to its nearest other point over its first `dims`
/// coordinates (INFINITY for a point alone).
std::vector<double> nearestDistances(const std::vector<Eigen::Matrix<double, 6, 1>>& points,
                                     int dims);

/// alpha's numerator and L for a set of endpoints: useful = no other endpoint within
/// `threshold` (distance <= threshold counts as within).
void endpointSpread(const std::vector<Eigen::Vector3d>& endpoints, double threshold, int* useful,
                    double* mean_nearest);

}  // namespace kinolab
