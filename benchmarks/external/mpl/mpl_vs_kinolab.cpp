// The Motion Primitive Library (MPL, Sikang Liu) against kinolab's motion-primitive searches
// on MPL's benchmark problem (experiments/mpl_benchmark.yaml), side by side in one process.
//
// The world, the queries and the problem's parameters come from kinolab's experiment file:
// MPL gets the same occupancy (a voxel map at the world's resolution and origin), the same
// double integrator (tau, the uniform control grid, v_max, a_max per axis), cost weight,
// epsilon and goal tolerance. Each round plans every query in turn with MPL and each kinolab
// variant (the order rotated per query and round); each (round, query, planner) is kinolab's timing
// protocol: one plan discarded, then `--repeats` timed plans, their median kept. MPL's time is
// a steady_clock around MPL::VoxelMapPlanner::plan(); kinolab's its own planning_time_ms.
//
//   mpl_vs_kinolab EXPERIMENT [--planner ID] [--threads 1,2] [--rounds 3] [--repeats 3]
//                  [--csv FILE]
//   mpl_vs_kinolab EXPERIMENT --write-map FILE
// The second writes the world's occupancy for mpl_plan_query (MPL's own process) and the
// queries, one "start goal" line each, to FILE.queries, then exits.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "kinolab/builtin_plugins.hpp"
#include "kinolab/experiment/experiment.hpp"
#include "kinolab/planner/planner.hpp"
#include "kinolab/world/world_cache.hpp"
#include "mpl_problem.hpp"

namespace {

struct Options {
  std::string experiment;
  std::string planner = "lazy";
  std::vector<int> threads = {1, 2};
  int rounds = 3;
  int repeats = 3;
  std::string csv;
  std::string write_map;
};

// One plan's outcome.
struct Sample {
  double ms = NAN;
  double cost = NAN;
  double duration = NAN;
  double expansions = NAN;
  bool solved = false;
  double clearance = NAN;  ///< m, to the occupied cubes (first round)
  double inside_ms = NAN;  ///< time inside occupied voxels (first round)
  double setup_ms = NAN;   ///< a fresh kinolab planner's configuration and setup (cold)
  std::vector<Eigen::Vector3d> points;  ///< the trajectory every 1 ms (when asked for)
};

constexpr double kPointStep = 1e-3;  // s

// The exact distance from `point` to the nearest occupied voxel cube (0 inside one), up to
// `reach` metres.
double clearance(const kinolab::VoxelGrid& grid, const Eigen::Vector3d& point, double reach = 0.6) {
  const double res = grid.resolution();
  const Eigen::Vector3d local = (point - grid.origin()) / res;
  const int n = static_cast<int>(std::ceil(reach / res)) + 1;
  double best = reach;
  for (int x = static_cast<int>(std::floor(local.x())) - n; x <= local.x() + n; ++x)
    for (int y = static_cast<int>(std::floor(local.y())) - n; y <= local.y() + n; ++y)
      for (int z = static_cast<int>(std::floor(local.z())) - n; z <= local.z() + n; ++z) {
        const kinolab::VoxelIndex voxel(x, y, z);
        if (!grid.inside(voxel) || !grid.occupied(voxel)) continue;
        const Eigen::Vector3d low = Eigen::Vector3d(x, y, z);
        const Eigen::Vector3d gap =
            (low - local).cwiseMax(local - low - Eigen::Vector3d::Ones()).cwiseMax(0.0);
        best = std::min(best, gap.norm() * res);
      }
  return best;
}

double minimumClearance(const kinolab::VoxelGrid& grid,
                        const std::vector<Eigen::Vector3d>& points) {
  double best = INFINITY;
  for (const Eigen::Vector3d& point : points) best = std::min(best, clearance(grid, point));
  return best;
}

// The time (ms) the trajectory spends inside occupied voxels.
double insideMs(const kinolab::VoxelGrid& grid, const std::vector<Eigen::Vector3d>& points) {
  int inside = 0;
  for (const Eigen::Vector3d& point : points) {
    const Eigen::Vector3d local = (point - grid.origin()) / grid.resolution();
    const kinolab::VoxelIndex voxel = local.array().floor().cast<int>();
    inside += grid.inside(voxel) && grid.occupied(voxel);
  }
  return inside * kPointStep * 1e3;
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n == 0 ? NAN : n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

Options parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--help") {
      std::fputs(
          "usage: mpl_vs_kinolab EXPERIMENT [--planner ID] [--threads 1,2] [--rounds 3]\n"
          "                      [--repeats 3] [--csv FILE]\n"
          "       mpl_vs_kinolab EXPERIMENT --write-map FILE\n"
          "MPL against kinolab's planner ID on the experiment's world and queries, in one\n"
          "process (README.md); --write-map writes the map and queries for mpl_plan_query.\n",
          stdout);
      std::exit(0);
    } else if (arg == "--planner") {
      options.planner = value();
    } else if (arg == "--threads") {
      options.threads.clear();
      std::stringstream list(value());
      for (std::string item; std::getline(list, item, ',');)
        options.threads.push_back(std::stoi(item));
    } else if (arg == "--rounds") {
      options.rounds = std::stoi(value());
    } else if (arg == "--repeats") {
      options.repeats = std::stoi(value());
    } else if (arg == "--csv") {
      options.csv = value();
    } else if (arg == "--write-map") {
      options.write_map = value();
    } else if (options.experiment.empty()) {
      options.experiment = arg;
    } else {
      throw std::runtime_error("unexpected argument " + arg);
    }
  }
  if (options.experiment.empty())
    throw std::runtime_error("usage: mpl_vs_kinolab EXPERIMENT [...]");
  if (options.rounds < 1 || options.repeats < 1 || options.threads.empty())
    throw std::runtime_error("--rounds and --repeats must be at least 1, --threads not empty");
  return options;
}

// The occupancy of `grid` in MPL's layout: voxels x fastest (kinolab's z fastest), 100
// occupied, 0 free.
MPL::Tmap mplMap(const kinolab::VoxelGrid& grid) {
  const Eigen::Vector3i dims = grid.dims();
  MPL::Tmap map(grid.size(), 0);
  for (int z = 0; z < dims.z(); ++z)
    for (int y = 0; y < dims.y(); ++y)
      for (int x = 0; x < dims.x(); ++x)
        if (grid.occupied(grid.index(x, y, z))) map[x + dims.x() * (y + dims.y() * z)] = 100;
  return map;
}

// `grid` for mpl_plan_query (its format there) and the queries beside it, FILE.queries.
void writeMap(const std::string& path, const kinolab::VoxelGrid& grid,
              const std::vector<kinolab::PlanningQuery>& queries) {
  const MPL::Tmap map = mplMap(grid);
  const Eigen::Vector3d origin = grid.origin();
  const Eigen::Vector3i dims = grid.dims();
  const double header_origin[3] = {origin.x(), origin.y(), origin.z()};
  const std::int32_t header_dims[3] = {dims.x(), dims.y(), dims.z()};
  const double resolution = grid.resolution();
  std::ofstream out(path, std::ios::binary);
  out.write("MPLMAP1\n", 8);
  out.write(reinterpret_cast<const char*>(header_origin), sizeof header_origin);
  out.write(reinterpret_cast<const char*>(header_dims), sizeof header_dims);
  out.write(reinterpret_cast<const char*>(&resolution), sizeof resolution);
  out.write(reinterpret_cast<const char*>(map.data()), static_cast<std::streamsize>(map.size()));
  std::ofstream lines(path + ".queries");
  lines.precision(17);
  for (const kinolab::PlanningQuery& query : queries) {
    const Eigen::Vector3d s = query.start.col(0);
    const Eigen::Vector3d g = query.goal;
    lines << s.x() << ',' << s.y() << ',' << s.z() << ' ' << g.x() << ',' << g.y() << ',' << g.z()
          << '\n';
  }
  if (!out || !lines) throw std::runtime_error("cannot write " + path);
}

// MPL's planner set up for the problem: the occupancy of `world`, the planner's parameters.
class MplSide {
 public:
  MplSide(const kinolab::World& world, const kinolab::ParameterSet& p) {
    const kinolab::VoxelGrid& grid = world.grid();
    auto util = std::make_shared<MPL::VoxelMapUtil>();
    util->setMap(grid.origin(), grid.dims(), mplMap(grid), grid.resolution());

    if (p.integer("order") != 2 || p.real("weight_length") != 0 || p.real("weight_obstacle") != 0 ||
        p.real("robot_radius") != 0) {
      throw std::runtime_error(
          "MPL's planner here: order 2, cost weight_duration T + effort, a point");
    }
    MplProblem problem;
    problem.samples_per_axis = static_cast<int>(p.nested("sampler").integer("samples_per_axis"));
    problem.max_velocity = p.real("max_velocity");
    problem.max_acceleration = p.real("max_acceleration");
    problem.tau = p.real("tau");
    problem.time_weight = p.real("weight_duration") / p.real("weight_control");
    problem.epsilon = p.real("heuristic_weight");
    problem.goal_tolerance = p.real("goal_radius");
    planner_ = makeMplPlanner(util, problem);
    weight_control_ = p.real("weight_control");
  }

  // At rest at the query's start, to its goal position (restingWaypoint).
  Sample plan(const kinolab::PlanningQuery& query, bool points) {
    const Waypoint3D start = restingWaypoint(query.start.col(0));
    const Waypoint3D goal = restingWaypoint(query.goal);

    Sample sample;
    const auto begin = std::chrono::steady_clock::now();
    sample.solved = planner_->plan(start, goal);
    const auto end = std::chrono::steady_clock::now();
    sample.ms = std::chrono::duration<double, std::milli>(end - begin).count();
    if (sample.solved) {
      // MPL's cost is J + w T with w = weight_duration / weight_control; kinolab's
      // weight_duration T + weight_control J.
      sample.cost = weight_control_ * planner_->getTrajCost();
      sample.duration = planner_->getTraj().getTotalTime();
      sample.expansions = planner_->getExpandedNum();
      const auto trajectory = planner_->getTraj();
      for (double t = 0; points && t < sample.duration + 0.5 * kPointStep; t += kPointStep)
        sample.points.push_back(trajectory.evaluate(std::min(t, sample.duration)).pos);
    }
    return sample;
  }

 private:
  std::unique_ptr<MPL::VoxelMapPlanner> planner_;
  double weight_control_ = 1.0;
};

Sample planKinolab(kinolab::Planner& planner, const kinolab::PlanningQuery& query, bool points) {
  planner.reset();
  const kinolab::PlanResult result = planner.plan(query, kinolab::Budget{});
  Sample sample;
  sample.ms = result.planning_time_ms;
  sample.solved = result.status == kinolab::PlanStatus::kExact && result.check.valid;
  sample.cost = result.cost;
  sample.duration = result.trajectory.duration();
  for (const auto& [name, value] : result.statistics)
    if (name == "expansions") sample.expansions = value;
  for (double t = 0; points && t < sample.duration + 0.5 * kPointStep; t += kPointStep)
    sample.points.push_back(result.trajectory.evaluate(std::min(t, sample.duration)));
  return sample;
}

}  // namespace

int main(int argc, char** argv) try {
  const Options options = parse(argc, argv);
  kinolab::registerBuiltinPlugins();
  const kinolab::Experiment experiment = kinolab::Experiment::fromFile(options.experiment);
  const kinolab::ExperimentVariant& variant = experiment.variants.front();
  const kinolab::ExperimentWorld& world_spec = variant.worlds.front();
  const auto world = kinolab::WorldCache(kinolab::WorldCache::defaultDirectory())
                         .loadOrBuild(world_spec.spec)
                         .world;
  const std::vector<kinolab::PlanningQuery> queries =
      variant.queries.make(*world, world_spec.id, experiment.seed);
  if (!options.write_map.empty()) {
    writeMap(options.write_map, world->grid(), queries);
    return 0;
  }

  const auto entry =
      std::find_if(variant.planners.begin(), variant.planners.end(),
                   [&](const auto& planner) { return planner.id == options.planner; });
  if (entry == variant.planners.end()) throw std::runtime_error("no planner " + options.planner);

  // Planner 0 is MPL, then kinolab's at each thread count, then kinolab's at the first thread
  // count set up afresh for every plan ("cold": its per-planner tables, such as the lattice
  // heuristic's layers, start empty; the setup's time is reported apart).
  std::vector<std::string> names = {"mpl"};
  MplSide mpl(*world, entry->parameters);
  std::vector<std::vector<kinolab::ParameterAssignment>> items;
  std::vector<kinolab::ConfiguredPlanner> kino;
  for (const int threads : options.threads) {
    items.push_back(entry->assignments);
    items.back().push_back({"time_limit", "0", "mpl_vs_kinolab"});
    items.back().push_back({"threads", std::to_string(threads), "mpl_vs_kinolab"});
    kino.push_back(kinolab::configurePlanner(entry->type, items.back()));
    kino.back().planner->setup({world, 1});
    names.push_back(options.planner + "_t" + std::to_string(threads));
  }
  names.push_back(names[1] + "_cold");
  const auto planCold = [&](const kinolab::PlanningQuery& query, bool points) {
    const auto begin = std::chrono::steady_clock::now();
    kinolab::ConfiguredPlanner fresh = kinolab::configurePlanner(entry->type, items.front());
    fresh.planner->setup({world, 1});
    const auto end = std::chrono::steady_clock::now();
    Sample sample = planKinolab(*fresh.planner, query, points);
    sample.setup_ms = std::chrono::duration<double, std::milli>(end - begin).count();
    return sample;
  };
  const std::size_t np = names.size();
  const std::size_t nq = queries.size();

  // samples[round][query][planner]: the median of the timed plans (figures of the last one).
  std::vector<std::vector<std::vector<Sample>>> samples(
      options.rounds, std::vector<std::vector<Sample>>(nq, std::vector<Sample>(np)));
  for (int round = 0; round < options.rounds; ++round) {
    for (std::size_t q = 0; q < nq; ++q) {
      for (std::size_t k = 0; k < np; ++k) {
        const std::size_t i = (k + static_cast<std::size_t>(round) + q) % np;
        const auto once = [&](bool points) {
          if (i == 0) return mpl.plan(queries[q], points);
          if (i == np - 1) return planCold(queries[q], points);
          return planKinolab(*kino[i - 1].planner, queries[q], points);
        };
        once(false);  // warm-up, discarded
        std::vector<double> times, setups;
        for (int r = 0; r < options.repeats; ++r) {
          const Sample timed = once(false);
          times.push_back(timed.ms);
          setups.push_back(timed.setup_ms);
        }
        // Once more, untimed, for the figures (and in the first round the trajectory's
        // clearance to the occupied cubes).
        Sample last = once(round == 0);
        last.clearance = minimumClearance(world->grid(), last.points);
        last.inside_ms = insideMs(world->grid(), last.points);
        last.points.clear();
        last.ms = median(times);
        last.setup_ms = median(setups);
        samples[round][q][i] = last;
      }
    }
    std::fprintf(stderr, "round %d of %d done\n", round + 1, options.rounds);
  }

  std::ofstream csv;
  if (!options.csv.empty()) {
    csv.open(options.csv);
    csv << "round,query,planner,ms,cost,duration,expansions,solved,clearance,inside_ms,setup_ms\n";
    for (int round = 0; round < options.rounds; ++round)
      for (std::size_t q = 0; q < nq; ++q)
        for (std::size_t i = 0; i < np; ++i) {
          const Sample& s = samples[round][q][i];
          csv << round << ',' << q << ',' << names[i] << ',' << s.ms << ',' << s.cost << ','
              << s.duration << ',' << s.expansions << ',' << s.solved << ',' << s.clearance << ','
              << s.inside_ms << ',' << s.setup_ms << '\n';
        }
  }

  // Per query: the fastest time over the rounds (ms), the first round's cost, expansions and
  // clearance to the occupied cubes (cm).
  std::printf("query start -> goal                    ");
  for (const auto& name : names) std::printf("| %-8s    ms   cost     N  cm ", name.c_str());
  std::printf("\n");
  std::vector<std::vector<double>> best(np, std::vector<double>(nq, INFINITY));
  std::vector<int> identical(np, 0);
  for (std::size_t q = 0; q < nq; ++q) {
    const Eigen::Vector3d s = queries[q].start.col(0);
    const Eigen::Vector3d g = queries[q].goal;
    std::printf("q%02zu (%5.2f,%5.2f,%4.2f) (%5.2f,%5.2f,%4.2f) ", q, s.x(), s.y(), s.z(), g.x(),
                g.y(), g.z());
    for (std::size_t i = 0; i < np; ++i) {
      for (int round = 0; round < options.rounds; ++round)
        best[i][q] = std::min(best[i][q], samples[round][q][i].ms);
      const Sample& first = samples[0][q][i];
      const double reference = samples[0][q][0].cost;
      identical[i] +=
          first.solved && std::abs(first.cost - reference) <= 1e-6 * std::abs(reference);
      std::printf("| %11.3f %6.1f %5.0f %3.0f ", best[i][q], first.cost, first.expansions,
                  100 * first.clearance);
    }
    std::printf("\n");
  }

  // Per planner: medians over the queries; the ratio MPL / planner is the median over the
  // queries of the per-query ratio, for each round, then of the fastest times over rounds.
  std::printf("\nplanner        median ms  median N  solved  cost = MPL's  MPL/it by round");
  std::printf("%*s(fastest)\n", std::max(0, 9 * options.rounds - 15), "");
  for (std::size_t i = 0; i < np; ++i) {
    std::vector<double> expansions;
    int solved = 0;
    for (std::size_t q = 0; q < nq; ++q) {
      expansions.push_back(samples[0][q][i].expansions);
      solved += samples[0][q][i].solved;
    }
    std::printf("%-13s %10.3f %9.0f %4d/%zu %8d/%zu   ", names[i].c_str(), median(best[i]),
                median(expansions), solved, nq, identical[i], nq);
    if (i > 0) {
      for (int round = 0; round < options.rounds; ++round) {
        std::vector<double> ratios;
        for (std::size_t q = 0; q < nq; ++q)
          ratios.push_back(samples[round][q][0].ms / samples[round][q][i].ms);
        std::printf(" %7.1fx", median(ratios));
      }
      std::vector<double> ratios;
      for (std::size_t q = 0; q < nq; ++q) ratios.push_back(best[0][q] / best[i][q]);
      std::printf("  (%.1fx)", median(ratios));
    }
    std::printf("\n");
  }
  std::vector<double> setups;
  for (int round = 0; round < options.rounds; ++round)
    for (std::size_t q = 0; q < nq; ++q) setups.push_back(samples[round][q][np - 1].setup_ms);
  std::printf("%s: configuration and setup before each plan, median %.3f ms (not in its time)\n",
              names[np - 1].c_str(), median(setups));
  return 0;
} catch (const std::exception& error) {
  std::fprintf(stderr, "mpl_vs_kinolab: %s\n", error.what());
  return 1;
}
