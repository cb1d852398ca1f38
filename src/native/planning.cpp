// Planning area of turtlebot_recon._native: distance field, inflated costmap, A*, Dijkstra,
// nearest accessible cell and line-of-sight shortcut. The algorithms live in the headers
// (no pybind11 there); this file only converts numpy arrays, checks shapes and releases the
// GIL around the loops. Grids are row-major (rows, cols), row 0 = smallest y; cells are
// (row, col) tuples.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/costmap.hpp"
#include "turtlebot_recon/distance_field.hpp"
#include "turtlebot_recon/grid_search.hpp"

namespace py = pybind11;
namespace tp = turtlebot_recon::planning;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

using CellArg = std::pair<int, int>;

std::string shape_str(Shape s) {
  return "(" + std::to_string(s.rows) + ", " + std::to_string(s.cols) + ")";
}

void check_resolution(double resolution, const char* fn) {
  if (!(std::isfinite(resolution) && resolution > 0))
    fail(fn, "resolution must be a positive number of metres, got " + std::to_string(resolution));
}

// visits must match the costmap's shape; returns its data or nullptr when absent.
const std::int32_t* visits_data(const std::optional<I32Array>& visits, Shape s, const char* fn) {
  if (!visits) return nullptr;
  const Shape v = grid_shape(*visits, fn, "visits");
  if (v.rows != s.rows || v.cols != s.cols)
    fail(fn, "visits has shape " + shape_str(v) + ", the costmap " + shape_str(s));
  return visits->data();
}

py::array_t<std::int32_t> cells_to_array(const std::vector<tp::Cell>& cells) {
  py::array_t<std::int32_t> out({static_cast<py::ssize_t>(cells.size()), py::ssize_t{2}});
  auto o = out.mutable_unchecked<2>();
  for (size_t i = 0; i < cells.size(); ++i) {
    o(i, 0) = cells[i].row;
    o(i, 1) = cells[i].col;
  }
  return out;
}

py::array_t<float> py_distance_transform(const U8Grid& mask, double resolution) {
  const Shape s = grid_shape(mask, "distance_transform", "mask");
  check_resolution(resolution, "distance_transform");
  py::array_t<float> out({s.rows, s.cols});
  float* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    tp::distance_transform(mask.data(), s.rows, s.cols, resolution, dst);
  }
  return out;
}

py::array_t<std::uint8_t> py_inflate(const I8Grid& occupancy, double resolution,
                                     double inscribed_radius_m, double inflation_radius_m,
                                     double cost_scaling_factor, int occupied_threshold,
                                     bool unknown_is_obstacle) {
  const Shape s = grid_shape(occupancy, "inflate", "occupancy");
  const tp::InflationParams p{resolution,         inscribed_radius_m, inflation_radius_m,
                              cost_scaling_factor, occupied_threshold, unknown_is_obstacle};
  tp::validate(p);
  py::array_t<std::uint8_t> out({s.rows, s.cols});
  std::uint8_t* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    tp::inflate(occupancy.data(), s.rows, s.cols, p, dst);
  }
  return out;
}

py::tuple py_astar(const U8Grid& costmap, CellArg start, CellArg goal,
                   const std::optional<I32Array>& visits, double visit_sensitivity,
                   double cost_weight, int unknown_cost, int lethal_cost, double resolution) {
  const Shape s = grid_shape(costmap, "astar", "costmap");
  const std::int32_t* v = visits_data(visits, s, "astar");
  const tp::CostModel model{resolution, visit_sensitivity, cost_weight, unknown_cost, lethal_cost};
  tp::GridPath path;
  {
    py::gil_scoped_release release;
    tp::GridSearch search(costmap.data(), v, s.rows, s.cols, model, "astar");
    path = search.astar({start.first, start.second}, {goal.first, goal.second});
  }
  return py::make_tuple(cells_to_array(path.cells), path.cost);
}

py::array_t<float> py_dijkstra(const U8Grid& costmap, CellArg start,
                               const std::optional<I32Array>& visits, double visit_sensitivity,
                               double cost_weight, int unknown_cost, int lethal_cost,
                               double resolution, const std::optional<I32Array>& targets) {
  const Shape s = grid_shape(costmap, "dijkstra", "costmap");
  const std::int32_t* v = visits_data(visits, s, "dijkstra");
  std::vector<tp::Cell> target_cells;
  if (targets) {
    const std::int32_t* t = targets->data();
    for (size_t i = 0, n = cell_count(*targets, "dijkstra", "targets"); i < n; ++i)
      target_cells.push_back({t[2 * i], t[2 * i + 1]});
  }
  const tp::CostModel model{resolution, visit_sensitivity, cost_weight, unknown_cost, lethal_cost};
  py::array_t<float> out({s.rows, s.cols});
  float* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    tp::GridSearch search(costmap.data(), v, s.rows, s.cols, model, "dijkstra");
    search.dijkstra({start.first, start.second}, dst, target_cells);
  }
  return out;
}

py::object py_nearest_accessible(const U8Grid& costmap, CellArg cell, int max_cost,
                                 double max_radius_m, double resolution) {
  const Shape s = grid_shape(costmap, "nearest_accessible", "costmap");
  check_resolution(resolution, "nearest_accessible");
  if (max_cost < 0 || max_cost > tp::kLethalObstacle)
    fail("nearest_accessible", "max_cost must be in 0..254, got " + std::to_string(max_cost));
  if (!(std::isfinite(max_radius_m) && max_radius_m >= 0))
    fail("nearest_accessible", "max_radius_m must be >= 0");
  tp::Cell found{};
  bool ok;
  {
    py::gil_scoped_release release;
    ok = tp::nearest_accessible(costmap.data(), s.rows, s.cols, {cell.first, cell.second},
                                max_cost, max_radius_m, resolution, &found);
  }
  if (!ok) return py::none();
  return py::make_tuple(found.row, found.col);
}

py::array_t<std::int32_t> py_shortcut(const I32Array& path, const U8Grid& costmap,
                                      int lethal_cost) {
  const Shape s = grid_shape(costmap, "shortcut", "costmap");
  const std::size_t n = cell_count(path, "shortcut", "path");
  std::vector<tp::Cell> cells(n), out;
  const std::int32_t* p = path.data();
  {
    py::gil_scoped_release release;
    for (size_t i = 0; i < n; ++i) cells[i] = {p[2 * i], p[2 * i + 1]};
    out = tp::shortcut_path(cells, costmap.data(), s.rows, s.cols, lethal_cost);
  }
  return cells_to_array(out);
}

}  // namespace

void register_planning(py::module_& m) {
  m.def("distance_transform", &py_distance_transform, py::arg("mask"), py::arg("resolution"),
        "Exact Euclidean distance (m, float32) from each cell centre to the nearest cell whose\n"
        "mask != 0: 0 on those cells, +inf everywhere if there is none (Felzenszwalb &\n"
        "Huttenlocher 2012, columns then rows). mask: uint8 (rows, cols).");
  m.def("inflate", &py_inflate, py::arg("occupancy"), py::arg("resolution"),
        py::arg("inscribed_radius_m"), py::arg("inflation_radius_m"),
        py::arg("cost_scaling_factor"), py::arg("occupied_threshold"),
        py::arg("unknown_is_obstacle"),
        "Inflated costmap (uint8, Nav2 convention) from ROS int8 occupancy (-1 unknown, 0..100):\n"
        "254 on obstacles (value >= occupied_threshold, or unknown if unknown_is_obstacle),\n"
        "253 within inscribed_radius_m, floor(252 exp(-k (d - inscribed))) up to\n"
        "inflation_radius_m, 0 beyond, 255 on unknown cells that are not obstacles.");
  m.def("astar", &py_astar, py::arg("costmap"), py::arg("start"), py::arg("goal"),
        py::arg("visits") = py::none(), py::arg("visit_sensitivity"),
        py::arg("cost_weight"), py::arg("unknown_cost"), py::arg("lethal_cost"),
        py::arg("resolution"),
        "A* on the 8-connected costmap from start to goal ((row, col) tuples), no corner cutting.\n"
        "Entering cell b over a step of L metres costs\n"
        "L * (1 + cost_weight * c_b / 252 + visit_sensitivity * visits_b); cells with cost >=\n"
        "lethal_cost are impassable, unknown (255) ones too unless unknown_cost >= 0 (then\n"
        "their cost). resolution (m) scales the cost only.\n"
        "Returns (path int32 (n, 2) start..goal, cost in metres); ((0, 2) array, inf) if the goal\n"
        "is unreachable. ValueError if start or goal is off the grid or impassable. The cost is\n"
        "optimal to a relative 1e-9 (the heuristic's tie-break).");
  m.def("dijkstra", &py_dijkstra, py::arg("costmap"), py::arg("start"),
        py::arg("visits") = py::none(), py::arg("visit_sensitivity"),
        py::arg("cost_weight"), py::arg("unknown_cost"), py::arg("lethal_cost"),
        py::arg("resolution"), py::arg("targets") = py::none(),
        "Cost-to-come (float32 (rows, cols), metres weighted as in astar) from start to every\n"
        "cell; +inf where unreachable or impassable. targets: an (n, 2) array of cells (None or\n"
        "empty: every cell); the search then stops once all of them are settled, and only the cells settled by then\n"
        "(every one cheaper than the dearest target) hold their cost, the rest +inf.");
  m.def("nearest_accessible", &py_nearest_accessible, py::arg("costmap"), py::arg("cell"),
        py::arg("max_cost"), py::arg("max_radius_m"), py::arg("resolution"),
        "The known cell nearest to `cell` (Euclidean; ties to the smaller row, then column) with\n"
        "cost <= max_cost, within max_radius_m, as (row, col); None if there is none. `cell` may\n"
        "be inaccessible or outside the grid.");
  m.def("shortcut", &py_shortcut, py::arg("path"), py::arg("costmap"), py::arg("lethal_cost"),
        "Line-of-sight simplification of an (n, 2) path: from each kept point, jump to the\n"
        "farthest later point whose Bresenham line crosses only cells with cost < lethal_cost\n"
        "and <= the highest cost of the path between them. Keeps the first and last points.");
}
