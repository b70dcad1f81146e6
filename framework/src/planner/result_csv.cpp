#include "kinolab/planner/result_csv.hpp"

#include <cstdio>

namespace kinolab {

std::string trajectoryCsv(const Trajectory& trajectory, double step) {
  std::string text = "t,x,y,z,vx,vy,vz,ax,ay,az,jx,jy,jz\n";
  char line[512];
  for (const auto& s : trajectory.sample(step)) {
    std::snprintf(line, sizeof(line),
                  "%.6f,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", s.time,
                  s.position.x(), s.position.y(), s.position.z(), s.velocity.x(), s.velocity.y(),
                  s.velocity.z(), s.acceleration.x(), s.acceleration.y(), s.acceleration.z(),
                  s.jerk.x(), s.jerk.y(), s.jerk.z());
    text += line;
  }
  return text;
}

std::string treeCsv(const SearchTree& tree) {
  std::string text = "edge,point,x,y,z,state,closed\n";
  char line[256];
  for (std::size_t e = 0; e < tree.size(); ++e) {
    const auto& edge = tree[e];
    const std::string state(toString(edge.state));
    for (std::size_t p = 0; p < edge.points.size(); ++p) {
      std::snprintf(line, sizeof(line), "%zu,%zu,%.6g,%.6g,%.6g,%s,%d\n", e, p, edge.points[p].x(),
                    edge.points[p].y(), edge.points[p].z(), state.c_str(), edge.closed ? 1 : 0);
      text += line;
    }
  }
  return text;
}

}  // namespace kinolab
