// Lattice area of turtlebot_recon._native: the state-lattice A* for an oriented footprint
// (include/turtlebot_recon/lattice_search.hpp). This file only converts numpy arrays and
// releases the GIL around the search. Grids are row-major (rows, cols), row 0 = smallest y.
// Every function here takes the footprint's regions and the map's products from one cache
// (lattice_grid.hpp's LatticeCache): a replan on an unchanged map, or the costmap and the
// reach of one map, build them once.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/footprint.hpp"
#include "turtlebot_recon/lattice_search.hpp"

namespace py = pybind11;
namespace tp = turtlebot_recon::planning;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

tp::LatticeCache cache;  // the module's: shared by every call, whichever thread makes it

// A search over `occupancy` for this robot and these parameters, from the cache.
tp::LatticeSearch search_over(const I8Grid& occupancy, const Shape& s, const tp::Footprint& footprint,
                              const tp::LatticeParams& params) {
  auto shapes = cache.shapes(footprint, params, static_cast<int>(s.cols));
  auto map = cache.map(occupancy.data(), static_cast<int>(s.rows), static_cast<int>(s.cols), shapes);
  return tp::LatticeSearch(shapes, map);
}

py::dict py_plan_lattice(const I8Grid& occupancy, double resolution, std::pair<int, int> start,
                         double start_yaw, std::pair<int, int> goal, std::optional<double> goal_yaw,
                         double footprint_length_m, double footprint_width_m,
                         double footprint_offset_x_m, double radius_m, int headings,
                         double margin_m, double turn_margin_m, double cost_weight,
                         double inflation_m, double cost_scaling_factor,
                         double turn_cost_m_per_rad, int occupied_threshold,
                         bool unknown_is_obstacle, double reverse_cost_factor) {
  const Shape s = grid_shape(occupancy, "plan_lattice", "occupancy");
  if (!std::isfinite(start_yaw) || (goal_yaw && !std::isfinite(*goal_yaw)))
    fail("plan_lattice", "start_yaw and goal_yaw must be finite");
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  const tp::LatticeParams params{resolution,   headings,          margin_m,
                                 turn_margin_m, cost_weight,      inflation_m,
                                 cost_scaling_factor, turn_cost_m_per_rad, occupied_threshold,
                                 unknown_is_obstacle, reverse_cost_factor};
  tp::LatticePath path;
  std::vector<tp::LatticeHeading> table;
  {
    py::gil_scoped_release release;
    tp::LatticeSearch search = search_over(occupancy, s, footprint, params);
    table = search.headings();
    const int k0 = tp::nearest_heading(table, start_yaw);
    const int k1 = goal_yaw ? tp::nearest_heading(table, *goal_yaw) : -1;
    path = search.plan({start.first, start.second}, k0, {goal.first, goal.second}, k1);
  }
  const auto n = static_cast<py::ssize_t>(path.states.size());
  py::array_t<std::int32_t> cells({n, py::ssize_t{2}});
  py::array_t<std::int32_t> heading(n);
  py::array_t<double> yaw(n);
  py::array_t<bool> turned(n);
  py::array_t<bool> reversed(n);
  auto c = cells.mutable_unchecked<2>();
  auto h = heading.mutable_unchecked<1>();
  auto y = yaw.mutable_unchecked<1>();
  auto t = turned.mutable_unchecked<1>();
  auto b = reversed.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const tp::LatticeState& st = path.states[i];
    c(i, 0) = st.row;
    c(i, 1) = st.col;
    h(i) = st.heading;
    y(i) = table[st.heading].yaw_rad;
    t(i) = st.turned;
    b(i) = st.reversed;
  }
  py::dict out;
  out["cells"] = cells;
  out["heading"] = heading;
  out["yaw"] = yaw;
  out["turned"] = turned;
  out["reversed"] = reversed;
  out["reversed_m"] = path.reversed_m;
  out["cost"] = path.cost;
  out["length_m"] = path.length_m;
  out["turned_rad"] = path.turned_rad;
  out["expanded"] = path.expanded;
  return out;
}

py::array_t<std::uint8_t> py_footprint_costmap(const I8Grid& occupancy, double resolution,
                                               double footprint_length_m, double footprint_width_m,
                                               double footprint_offset_x_m, double radius_m,
                                               double margin_m, double inflation_m,
                                               double cost_scaling_factor, int occupied_threshold,
                                               bool unknown_is_obstacle) {
  const Shape s = grid_shape(occupancy, "footprint_costmap", "occupancy");
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  tp::LatticeParams params;
  params.resolution_m = resolution;
  params.margin_m = margin_m;
  params.inflation_m = inflation_m;
  params.cost_scaling_factor = cost_scaling_factor;
  params.occupied_threshold = occupied_threshold;
  params.unknown_is_obstacle = unknown_is_obstacle;
  py::array_t<std::uint8_t> out({s.rows, s.cols});
  std::uint8_t* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    search_over(occupancy, s, footprint, params).costmap(dst);
  }
  return out;
}

py::array_t<float> py_lattice_cost_to_come(const I8Grid& occupancy, double resolution,
                                            std::pair<int, int> start, double start_yaw,
                                            double snap_radius_m, double footprint_length_m,
                                            double footprint_width_m, double footprint_offset_x_m,
                                            double radius_m, int headings, double margin_m,
                                            double turn_margin_m, double cost_weight,
                                            double inflation_m, double cost_scaling_factor,
                                            double turn_cost_m_per_rad, int occupied_threshold,
                                            bool unknown_is_obstacle, double reverse_cost_factor,
                                            const std::vector<std::tuple<int, int, int, double>>& extra_seeds,
                                            double turns_within_m) {
  const Shape s = grid_shape(occupancy, "lattice_cost_to_come", "occupancy");
  if (!(turns_within_m >= 0)) fail("lattice_cost_to_come", "turns_within_m must be >= 0 (inf: everywhere)");
  if (!std::isfinite(start_yaw)) fail("lattice_cost_to_come", "start_yaw must be finite");
  if (!(std::isfinite(snap_radius_m) && snap_radius_m >= 0))
    fail("lattice_cost_to_come", "snap_radius_m must be >= 0");
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  const tp::LatticeParams params{resolution,   headings,          margin_m,
                                 turn_margin_m, cost_weight,      inflation_m,
                                 cost_scaling_factor, turn_cost_m_per_rad, occupied_threshold,
                                 unknown_is_obstacle, reverse_cost_factor};
  std::vector<tp::LatticeSeed> extra;
  for (const auto& [row, col, heading, cost] : extra_seeds) extra.push_back({{row, col}, heading, cost});
  py::array_t<float> out({s.rows, s.cols});
  float* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    tp::LatticeSearch search = search_over(occupancy, s, footprint, params);
    search.reach_from({start.first, start.second}, start_yaw,
                      static_cast<int>(snap_radius_m / resolution), extra, dst, turns_within_m);
  }
  return out;
}

// footprint_clear (margin_m) and footprint_clearance (max_m): one answer per (x, y, yaw) pose.
template <class Out, class PerPose>
py::array_t<Out> per_pose(const char* fn, const I8Grid& occupancy, double resolution,
                          std::pair<double, double> origin,
                          const py::array_t<double, kInFlags>& poses, double footprint_length_m,
                          double footprint_width_m, double footprint_offset_x_m, double radius_m,
                          double distance_m, int occupied_threshold, bool unknown_is_obstacle,
                          PerPose&& answer) {
  const Shape s = grid_shape(occupancy, fn, "occupancy");
  if (!(poses.size() == 0 || (poses.ndim() == 2 && poses.shape(1) == 3)))
    fail(fn, "poses must be an (n, 3) array of (x, y, yaw)");
  if (!(std::isfinite(resolution) && resolution > 0))
    fail(fn, "resolution must be a positive number of metres");
  if (!(std::isfinite(distance_m) && distance_m > 0))
    fail(fn, "margin_m / max_m must be > 0");
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  tp::validate(footprint, fn);
  const auto n = static_cast<py::ssize_t>(poses.size() / 3);
  py::array_t<Out> out(n);
  Out* dst = out.mutable_data();
  const double* p = poses.data();
  const std::int8_t* occ = occupancy.data();
  {
    py::gil_scoped_release release;
    auto is_obstacle = [&](int r, int c) {
      if (r < 0 || r >= s.rows || c < 0 || c >= s.cols) return unknown_is_obstacle;
      const std::int8_t v = occ[static_cast<size_t>(r) * s.cols + c];
      return v >= occupied_threshold || (v < 0 && unknown_is_obstacle);
    };
    for (py::ssize_t i = 0; i < n; ++i) {
      const double x = p[3 * i] - origin.first, y = p[3 * i + 1] - origin.second, yaw = p[3 * i + 2];
      const bool finite = std::isfinite(x) && std::isfinite(y) && std::isfinite(yaw);
      dst[i] = answer(footprint, finite, x, y, yaw, is_obstacle);
    }
  }
  return out;
}

py::array_t<bool> py_footprint_clear(const I8Grid& occupancy, double resolution,
                                     std::pair<double, double> origin,
                                     const py::array_t<double, kInFlags>& poses,
                                     double footprint_length_m, double footprint_width_m,
                                     double footprint_offset_x_m, double radius_m, double margin_m,
                                     int occupied_threshold, bool unknown_is_obstacle) {
  return per_pose<bool>(
      "footprint_clear", occupancy, resolution, origin, poses, footprint_length_m,
      footprint_width_m, footprint_offset_x_m, radius_m, margin_m, occupied_threshold,
      unknown_is_obstacle,
      [&](const tp::Footprint& fp, bool finite, double x, double y, double yaw, auto& is_obstacle) {
        return finite && tp::footprint_clear_at(fp, margin_m, resolution, x, y, yaw, is_obstacle);
      });
}

py::array_t<double> py_footprint_clearance(const I8Grid& occupancy, double resolution,
                                           std::pair<double, double> origin,
                                           const py::array_t<double, kInFlags>& poses,
                                           double footprint_length_m, double footprint_width_m,
                                           double footprint_offset_x_m, double radius_m,
                                           double max_m, int occupied_threshold,
                                           bool unknown_is_obstacle) {
  return per_pose<double>(
      "footprint_clearance", occupancy, resolution, origin, poses, footprint_length_m,
      footprint_width_m, footprint_offset_x_m, radius_m, max_m, occupied_threshold,
      unknown_is_obstacle,
      [&](const tp::Footprint& fp, bool finite, double x, double y, double yaw, auto& is_obstacle) {
        return finite ? tp::footprint_clearance_at(fp, max_m, resolution, x, y, yaw, is_obstacle)
                      : 0.0;
      });
}

py::list py_lattice_headings(int headings) {
  py::list out;
  for (const tp::LatticeHeading& h : tp::lattice_headings(headings))
    out.append(py::make_tuple(h.dr, h.dc, h.yaw_rad));
  return out;
}

}  // namespace

void register_lattice(py::module_& m) {
  m.def("plan_lattice", &py_plan_lattice, py::arg("occupancy"), py::arg("resolution"),
        py::arg("start"), py::arg("start_yaw"), py::arg("goal"), py::arg("goal_yaw") = py::none(),
        py::arg("footprint_length_m"), py::arg("footprint_width_m"),
        py::arg("footprint_offset_x_m"), py::arg("radius_m"),
        py::arg("headings"), py::arg("margin_m"), py::arg("turn_margin_m"),
        py::arg("cost_weight"), py::arg("inflation_m"),
        py::arg("cost_scaling_factor"), py::arg("turn_cost_m_per_rad"),
        py::arg("occupied_threshold"), py::arg("unknown_is_obstacle"),
        py::arg("reverse_cost_factor"),
        "State-lattice A* over (row, col, heading) on ROS int8 occupancy (-1 unknown, 0..100) for\n"
        "a box footprint (length x width, centre offset_x ahead of base_footprint; length 0: a\n"
        "disc of radius_m). start, goal: (row, col) cells; start_yaw (rad) and goal_yaw (None: any\n"
        "heading) snap to the nearest of `headings` lattice headings. Moves: forward one lattice\n"
        "vector with the swept box (padded by margin_m, measured to obstacle edges) clear; turn in\n"
        "place where the disc of radius_m + turn_margin_m and every padded pose are clear, or the\n"
        "box swept to the next heading is; backward one lattice vector (reverse_cost_factor > 0)\n"
        "where the forward move from its end is valid. Cost (m): L (1 + cost_weight c / 252)\n"
        "forward, reverse_cost_factor x that backward, turn_cost_m_per_rad |dtheta| turning.\n"
        "Returns a dict: cells int32 (n, 2), heading int32 (n,), yaw float64 (n,) rad, turned bool\n"
        "(n,) (reached by turning in place), reversed bool (n,) (by a backward move), cost,\n"
        "length_m, turned_rad, reversed_m, expanded; n = 0 and cost\n"
        "inf when the goal is unreachable. ValueError naming the start or goal when it is off the\n"
        "grid, in an obstacle, in unknown space or its footprint collides.");
  m.def("lattice_cost_to_come", &py_lattice_cost_to_come, py::arg("occupancy"),
        py::arg("resolution"), py::arg("start"), py::arg("start_yaw"),
        py::arg("snap_radius_m"), py::arg("footprint_length_m"),
        py::arg("footprint_width_m"), py::arg("footprint_offset_x_m"),
        py::arg("radius_m"), py::arg("headings"), py::arg("margin_m"),
        py::arg("turn_margin_m"), py::arg("cost_weight"),
        py::arg("inflation_m"), py::arg("cost_scaling_factor"),
        py::arg("turn_cost_m_per_rad"), py::arg("occupied_threshold"),
        py::arg("unknown_is_obstacle"), py::arg("reverse_cost_factor"),
        py::arg("extra_seeds"),
        py::arg("turns_within_m"),
        "float32 (rows, cols): the cheapest plan_lattice cost (m) from the robot at cell `start`\n"
        "with yaw start_yaw to each cell at its cheapest heading; inf where plan_lattice finds no\n"
        "path. Start states: every heading that fits where the turning disc does (each costing\n"
        "the turn), else the headings along the robot's line either way; when none fits, the\n"
        "nearest cell within snap_radius_m where one does; and extra_seeds, (row, col, heading,\n"
        "cost_m) states (escape arcs), at their cost. All inf when there is none. Past\n"
        "turns_within_m, turns in cells where the robot can turn in place are not counted (one\n"
        "node per such cell; the reach is the same, the costs there lower bounds).");
  m.def("footprint_costmap", &py_footprint_costmap, py::arg("occupancy"), py::arg("resolution"),
        py::arg("footprint_length_m"), py::arg("footprint_width_m"),
        py::arg("footprint_offset_x_m"), py::arg("radius_m"),
        py::arg("margin_m"), py::arg("inflation_m"),
        py::arg("cost_scaling_factor"), py::arg("occupied_threshold"),
        py::arg("unknown_is_obstacle"),
        "The graded costmap plan_lattice reads (uint8, Nav2 convention): 254 obstacle, 255 unknown,\n"
        "253 where no lattice heading of the footprint fits (exact; always where the nearest obstacle\n"
        "edge is nearer than the body's inscribed radius about base_footprint + margin_m),\n"
        "252 exp(-k (d - r_in)) out to inflation_m beyond, d to the obstacle's edge, 0 further.");
  m.def("footprint_clear", &py_footprint_clear, py::arg("occupancy"), py::arg("resolution"),
        py::arg("origin"), py::arg("poses"), py::arg("footprint_length_m"),
        py::arg("footprint_width_m"), py::arg("footprint_offset_x_m"),
        py::arg("radius_m"), py::arg("margin_m"),
        py::arg("occupied_threshold"), py::arg("unknown_is_obstacle"),
        "bool (n,): whether the footprint at each (x, y, yaw) pose (m, rad; any pose, not only\n"
        "lattice ones) keeps margin_m off every obstacle cell's square (occupancy >=\n"
        "occupied_threshold; unknown cells and cells off the grid too if unknown_is_obstacle).\n"
        "origin: (x, y) of cell (0, 0)'s corner. Non-finite poses are not clear.");
  m.def("footprint_clearance", &py_footprint_clearance, py::arg("occupancy"),
        py::arg("resolution"), py::arg("origin"), py::arg("poses"),
        py::arg("footprint_length_m"), py::arg("footprint_width_m"),
        py::arg("footprint_offset_x_m"), py::arg("radius_m"), py::arg("max_m"),
        py::arg("occupied_threshold"), py::arg("unknown_is_obstacle"),
        "float (n,): the distance (m) from the footprint at each (x, y, yaw) pose to the nearest\n"
        "obstacle cell's square (as footprint_clear counts them), 0 when they meet, max_m when\n"
        "none is nearer. Non-finite poses: 0.");
  m.def("lattice_headings", &py_lattice_headings, py::arg("headings"),
        "The lattice headings as (drow, dcol, yaw_rad): heading k moves forward by (drow, dcol).");
}
