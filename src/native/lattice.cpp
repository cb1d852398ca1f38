// Lattice area of turtlebot_recon._native: the state-lattice A* for an oriented footprint
// (include/turtlebot_recon/lattice_search.hpp). This file only converts numpy arrays and
// releases the GIL around the search. Grids are row-major (rows, cols), row 0 = smallest y.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <optional>
#include <utility>

#include "numpy_args.hpp"
#include "turtlebot_recon/footprint.hpp"
#include "turtlebot_recon/lattice_search.hpp"

namespace py = pybind11;
namespace tp = turtlebot_recon::planning;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

py::dict py_plan_lattice(const I8Grid& occupancy, double resolution, std::pair<int, int> start,
                         double start_yaw, std::pair<int, int> goal, std::optional<double> goal_yaw,
                         double footprint_length_m, double footprint_width_m,
                         double footprint_offset_x_m, double radius_m, int headings,
                         double margin_m, double turn_margin_m, double cost_weight,
                         double inflation_m, double cost_scaling_factor,
                         double turn_cost_m_per_rad, int occupied_threshold,
                         bool unknown_is_obstacle) {
  const Shape s = grid_shape(occupancy, "plan_lattice", "occupancy");
  if (!std::isfinite(start_yaw) || (goal_yaw && !std::isfinite(*goal_yaw)))
    fail("plan_lattice", "start_yaw and goal_yaw must be finite");
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  const tp::LatticeParams params{resolution,   headings,          margin_m,
                                 turn_margin_m, cost_weight,      inflation_m,
                                 cost_scaling_factor, turn_cost_m_per_rad, occupied_threshold,
                                 unknown_is_obstacle};
  tp::LatticePath path;
  std::vector<tp::LatticeHeading> table;
  {
    py::gil_scoped_release release;
    tp::LatticeSearch search(occupancy.data(), s.rows, s.cols, footprint, params);
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
  auto c = cells.mutable_unchecked<2>();
  auto h = heading.mutable_unchecked<1>();
  auto y = yaw.mutable_unchecked<1>();
  auto t = turned.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const tp::LatticeState& st = path.states[i];
    c(i, 0) = st.row;
    c(i, 1) = st.col;
    h(i) = st.heading;
    y(i) = table[st.heading].yaw_rad;
    t(i) = st.turned;
  }
  py::dict out;
  out["cells"] = cells;
  out["heading"] = heading;
  out["yaw"] = yaw;
  out["turned"] = turned;
  out["cost"] = path.cost;
  out["length_m"] = path.length_m;
  out["turned_rad"] = path.turned_rad;
  out["expanded"] = path.expanded;
  return out;
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
        py::arg("footprint_length_m") = 0.0, py::arg("footprint_width_m") = 0.0,
        py::arg("footprint_offset_x_m") = 0.0, py::arg("radius_m") = 0.105,
        py::arg("headings") = 16, py::arg("margin_m") = 0.02, py::arg("turn_margin_m") = 0.01,
        py::arg("cost_weight") = 1.0, py::arg("inflation_m") = 0.35,
        py::arg("cost_scaling_factor") = 5.0, py::arg("turn_cost_m_per_rad") = 0.325,
        py::arg("occupied_threshold") = 65, py::arg("unknown_is_obstacle") = false,
        "State-lattice A* over (row, col, heading) on ROS int8 occupancy (-1 unknown, 0..100) for\n"
        "a box footprint (length x width, centre offset_x ahead of base_footprint; length 0: a\n"
        "disc of radius_m). start, goal: (row, col) cells; start_yaw (rad) and goal_yaw (None: any\n"
        "heading) snap to the nearest of `headings` lattice headings. Moves: forward one lattice\n"
        "vector with the swept box (padded by margin_m, measured to obstacle edges) clear; turn in\n"
        "place where the disc of radius_m + turn_margin_m and every padded pose are clear. Cost\n"
        "(m): L (1 + cost_weight c / 252) forward, turn_cost_m_per_rad |dtheta| turning.\n"
        "Returns a dict: cells int32 (n, 2), heading int32 (n,), yaw float64 (n,) rad, turned bool\n"
        "(n,) (reached by turning in place), cost, length_m, turned_rad, expanded; n = 0 and cost\n"
        "inf when the goal is unreachable. ValueError naming the start or goal when it is off the\n"
        "grid, in an obstacle, in unknown space or its footprint collides.");
  m.def("lattice_headings", &py_lattice_headings, py::arg("headings") = 16,
        "The lattice headings as (drow, dcol, yaw_rad): heading k moves forward by (drow, dcol).");
}
