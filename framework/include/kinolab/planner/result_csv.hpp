#pragma once

#include <string>

#include "kinolab/planner/planner.hpp"

namespace kinolab {

/// `t,x,y,z,vx,vy,vz,ax,ay,az,jx,jy,jz`: the trajectory every `step` seconds and at the end.
std::string trajectoryCsv(const Trajectory& trajectory, double step);
/// `edge,point,x,y,z,state,closed`: one row per point of each search-tree edge.
std::string treeCsv(const SearchTree& tree);

}  // namespace kinolab
