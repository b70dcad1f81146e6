// MPL's own process for one query of MPL's benchmark problem: read the map, plan, print, exit;
// the counterpart of one `kinolab plan` process (whole_process.py runs both, interleaved).
//
// The map is the binary file `mpl_vs_kinolab --write-map` writes (the world's occupancy in
// MPL's layout, read with one fread: MPL's fastest way in, its own examples parse YAML). The
// problem is the benchmark's: order 2, tau 1 s, the 27 controls {-1, 0, 1}^3 (a_max 1), v_max
// 2, cost J + 10 T, epsilon 1, goal tolerance 0.01, start at rest as MPL's examples.
//
//   mpl_plan_query MAP START GOAL        (START, GOAL: x,y,z in metres)
// Prints one line: solved, cost, expansions, planning ms. Links MPL alone (no kinolab).

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mpl_problem.hpp"

namespace {

Vec3f point(const char* text) {
  Vec3f p;
  char comma1 = 0;
  char comma2 = 0;
  std::istringstream in(text);
  if (!(in >> p.x() >> comma1 >> p.y() >> comma2 >> p.z()) || comma1 != ',' || comma2 != ',')
    throw std::runtime_error(std::string("not a point x,y,z: ") + text);
  return p;
}

// The map file: "MPLMAP1\n", origin (3 doubles), dims (3 int32), resolution (double), then the
// voxels x fastest, one signed char each (100 occupied, 0 free).
std::shared_ptr<MPL::VoxelMapUtil> readMap(const char* path) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path, "rb"), &std::fclose);
  if (!file) throw std::runtime_error(std::string(path) + ": cannot open");
  char magic[8];
  double origin[3];
  std::int32_t dims[3];
  double resolution = 0;
  if (std::fread(magic, 1, 8, file.get()) != 8 || std::memcmp(magic, "MPLMAP1\n", 8) != 0 ||
      std::fread(origin, sizeof origin, 1, file.get()) != 1 ||
      std::fread(dims, sizeof dims, 1, file.get()) != 1 ||
      std::fread(&resolution, sizeof resolution, 1, file.get()) != 1 || dims[0] <= 0 ||
      dims[1] <= 0 || dims[2] <= 0 || !(resolution > 0))
    throw std::runtime_error(std::string(path) + ": not a map of mpl_vs_kinolab --write-map");
  MPL::Tmap map(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]);
  if (std::fread(map.data(), 1, map.size(), file.get()) != map.size())
    throw std::runtime_error(std::string(path) + ": truncated");
  auto util = std::make_shared<MPL::VoxelMapUtil>();
  util->setMap(Vec3f(origin[0], origin[1], origin[2]), Vec3i(dims[0], dims[1], dims[2]), map,
               resolution);
  return util;
}

}  // namespace

int main(int argc, char** argv) try {
  const char* usage =
      "usage: mpl_plan_query MAP START GOAL\n"
      "  Plans one query of MPL's benchmark problem with MPL alone and prints: solved, cost,\n"
      "  expansions, planning ms. MAP from `mpl_vs_kinolab EXPERIMENT --write-map MAP`;\n"
      "  START, GOAL: x,y,z in metres.\n";
  if (argc == 2 && std::strcmp(argv[1], "--help") == 0) {
    std::fputs(usage, stdout);
    return 0;
  }
  if (argc != 4) throw std::runtime_error(usage);
  const auto util = readMap(argv[1]);
  const auto planner = makeMplPlanner(util, MplProblem{});
  const Waypoint3D start = restingWaypoint(point(argv[2]));
  const Waypoint3D goal = restingWaypoint(point(argv[3]));

  const auto begin = std::chrono::steady_clock::now();
  const bool solved = planner->plan(start, goal);
  const auto end = std::chrono::steady_clock::now();
  std::printf("solved %d cost %.6f expansions %d planning_ms %.3f\n", solved ? 1 : 0,
              solved ? planner->getTrajCost() : -1.0, planner->getExpandedNum(),
              std::chrono::duration<double, std::milli>(end - begin).count());
  return solved ? 0 : 2;
} catch (const std::exception& error) {
  std::fprintf(stderr, "mpl_plan_query: %s\n", error.what());
  return 1;
}
