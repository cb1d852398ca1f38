// OMPL's sampling planners over the robot's oriented footprint: RRT-Connect, RRT*, Informed
// RRT*, PRM* and BIT* in SE(2), next to the state lattice (lattice_search.hpp).
//
// The motion model is the lattice's and the navigator's follower's: a differential-drive
// robot turns in place, drives straight, turns in place. A motion from (x1, y1, yaw1) to
// (x2, y2, yaw2) turns at p1 from yaw1 to the segment's direction d, drives forward along d
// to p2, turns at p2 from d to yaw2; or, where the robot may back (the lattice's backward
// moves, dearer by reverse_cost_factor), faces the other way and drives backward. It is valid
// when the footprint keeps `margin_m` off every obstacle cell's square all the way
// (turn_margin_m while turning; footprint.hpp's exact test, answered first by the distance
// field away from obstacles) and the robot's centre stays on known free cells (the lattice
// never enters unknown ones either). Its cost is the lattice's: metres driven (backward ones
// x reverse_cost_factor) plus turn_cost_m_per_rad per radian turned; the planners see the
// cheaper way, the validator says whether either is clear. Costs are not symmetric, nor,
// forward only, is validity (a box sweeps other cells turning at p1 than at p2), so the state
// space says so and RRT* checks each direction.
//
// The path-length objective is this cost; its heuristic, the SE(2) distance with the yaw
// weighted by a fifth of turn_cost_m_per_rad (|dp| + k |dyaw| / 5), never exceeds it (the
// turns of any path add up to at least the net change of heading), so RRT*'s, Informed
// RRT*'s and BIT*'s heuristics stay admissible. Half the samples are drawn where the robot
// can turn in place (its turning disc fits), a tenth on the start's and the goals' lines:
// uniform samples almost never land in a maze corridor's few centimetres about its centre
// line where a box robot turns, and without them no path rounds a corner. After the solve,
// OMPL's simplifier (vertex reduction, shortcuts, collapsing close vertices) shortens the
// path; then each inner vertex's yaw is set to the heading held on the segment into it (the
// path the follower drives: a turn at each vertex straight from one heading to the next),
// and that path is checked again (the planner's own path where the simplified one fails).
//
// Poses are in metres from the grid's corner (cell (0, 0) spans [0, res] x [0, res]); grids
// row-major, row 0 at the smallest y.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "turtlebot_recon/footprint.hpp"

namespace turtlebot_recon::planning {

struct SamplingRequest {
  std::string planner = "rrtconnect";  // rrtconnect | rrtstar | informed_rrtstar | prmstar |
                                       // bitstar
  double budget_s = 0.2;               // the solve's wall-time limit (s); the simplifier's is
                                       // as long again at most
  double margin_m = 0.02;              // body to obstacle edge (the lattice's margin_m)
  double turn_margin_m = 0.01;         // the same turning in place (the lattice's)
  double turn_cost_m_per_rad = 0.3;    // metres charged per radian turned (the lattice's)
  double reverse_cost_factor = 0.0;    // a backward metre costs this many forward ones (>= 1);
                                       // 0: forward only (the lattice's)
  int occupied_threshold = 65;         // occupancy >= this: obstacle
  bool simplify = true;
  std::array<double, 3> start{};       // x, y (m from the grid's corner), yaw (rad)
  std::array<double, 2> goal{};        // x, y (m from the grid's corner)
};

struct SampledPath {
  std::vector<std::array<double, 3>> poses;  // start ... goal, each inner yaw the heading held
                                             // on the segment into it
  std::vector<bool> reversed;  // per pose: the segment into it driven backward
  bool solved = false;       // an exact solution, valid as the follower drives it
  std::string reason;        // why not, when not solved
  double solve_s = 0.0;      // wall time of the planner's solve
  double simplify_s = 0.0;   // wall time of the simplification
  int vertices = 0;          // states in the planner's graph or trees when it stopped
  double length_m = 0.0;     // driven (x-y)
  double turned_rad = 0.0;   // turned in place, the start's and the goal's turns included
  double reversed_m = 0.0;   // of length_m, driven backward
  double cost_m = 0.0;       // driven (backward x reverse_cost_factor) + turn_cost_m_per_rad x turned
};

// The planners' names, in the order above.
const std::vector<std::string>& sampling_planners();

// Plans start -> goal for `footprint` on `occupancy` (rows x cols int8, -1 unknown, 0..100);
// the goal states are the goal's position at each of `goal_yaws` where the footprint fits.
// Throws std::invalid_argument for an unknown planner or a bad argument; a start or goal off
// the grid or where the footprint does not fit is a reason, not an exception.
SampledPath plan_sampling(const std::int8_t* occupancy, int rows, int cols, double resolution_m,
                          const Footprint& footprint, const SamplingRequest& request,
                          const std::vector<double>& goal_yaws);

// A 2-D path (`points` in metres from the grid's corner, e.g. A*'s cell centres; the first is
// the start, at request.start's yaw) made followable for `footprint`: from each kept pose, the
// farthest later point the robot reaches by turning in place to face it and driving straight
// (backward where the robot may back, reverse_cost_factor > 0), the body clear all the way with
// request's margins (the motions above); the scan stops at the first point not reached after
// one that is, as a line-of-sight shortcut's greedy rule, the sight being the swept footprint.
// The last point is reached at the heading held on the way. Not solved, with the reason, where
// a kept pose reaches no later point (A* on a footprint costmap passes cells where some
// heading fits, not always the one its path needs). Throws std::invalid_argument for a bad
// argument.
SampledPath shortcut_turn_drive(const std::int8_t* occupancy, int rows, int cols, double resolution_m,
                                const Footprint& footprint, const SamplingRequest& request,
                                const std::vector<std::array<double, 2>>& points);

}  // namespace turtlebot_recon::planning
