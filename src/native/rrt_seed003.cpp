// Seed 003's RRT in turtlebot_recon._native (include/turtlebot_recon/rrt_seed003.hpp): this file
// only converts numpy arrays, checks the start and goal, and releases the GIL around the search.
// Points are (x, y) in cells: x = column, y = row, cell (row, col) spans [col, col + 1) x
// [row, row + 1).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/rrt_seed003.hpp"

namespace py = pybind11;
namespace tp = turtlebot_recon::planning;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

tp::RrtSeed003Params params(int hitbox_width_cells, int hitbox_length_cells, int occupied_threshold,
                            bool unknown_is_obstacle) {
  tp::RrtSeed003Params p;
  p.hitbox_width_cells = hitbox_width_cells;
  p.hitbox_length_cells = hitbox_length_cells;
  p.occupied_threshold = occupied_threshold;
  p.unknown_is_obstacle = unknown_is_obstacle;
  return p;
}

std::string point_str(tp::Point2 p) {
  return "(" + std::to_string(p.x) + ", " + std::to_string(p.y) + ")";
}

// ValueError naming `what` (start or goal) when it is off the grid, in an obstacle cell or its
// hit-box overlaps one.
void check_end(const tp::HitBoxGrid& grid, tp::Point2 p, const char* what, const tp::RrtSeed003Params& params) {
  if (!(std::isfinite(p.x) && std::isfinite(p.y) && p.x >= 0 && p.y >= 0 && p.x < grid.cols() &&
        p.y < grid.rows()))
    fail("rrt_seed003", std::string(what) + " " + point_str(p) + " (x, y cells) is off the " +
                            std::to_string(grid.rows()) + " x " + std::to_string(grid.cols()) + " grid");
  if (grid.obstacle(static_cast<int>(std::floor(p.y)), static_cast<int>(std::floor(p.x))))
    fail("rrt_seed003", std::string(what) + " " + point_str(p) + " (x, y cells) is inside an obstacle");
  if (!grid.free_at(p))
    fail("rrt_seed003", std::string(what) + " " + point_str(p) + " (x, y cells): its " +
                            std::to_string(params.hitbox_width_cells) + " x " +
                            std::to_string(params.hitbox_length_cells) +
                            " cell hit-box meets an obstacle or the grid's edge");
}

py::array_t<double> points_array(const std::vector<tp::Point2>& pts) {
  py::array_t<double> out({static_cast<py::ssize_t>(pts.size()), py::ssize_t{2}});
  auto o = out.mutable_unchecked<2>();
  for (size_t i = 0; i < pts.size(); ++i) {
    o(i, 0) = pts[i].x;
    o(i, 1) = pts[i].y;
  }
  return out;
}

py::dict py_rrt_seed003(const I8Grid& occupancy, std::pair<double, double> start,
                        std::pair<double, double> goal, std::uint32_t seed, double goal_fraction,
                        double step_cells, int hitbox_width_cells, int hitbox_length_cells,
                        int max_steps, int max_nodes, bool shortcut, int occupied_threshold,
                        bool unknown_is_obstacle) {
  const Shape s = grid_shape(occupancy, "rrt_seed003", "occupancy");
  tp::RrtSeed003Params p = params(hitbox_width_cells, hitbox_length_cells, occupied_threshold,
                                  unknown_is_obstacle);
  p.goal_fraction = goal_fraction;
  p.step_cells = step_cells;
  p.max_steps = max_steps;
  p.max_nodes = max_nodes;
  p.shortcut = shortcut;
  const tp::Point2 a{start.first, start.second}, b{goal.first, goal.second};
  const tp::RrtSeed003 rrt(occupancy.data(), s.rows, s.cols, p);
  check_end(rrt.grid(), a, "start", p);
  check_end(rrt.grid(), b, "goal", p);
  tp::RrtSeed003Result r;
  {
    py::gil_scoped_release release;
    r = rrt.plan(a, b, seed);
  }
  py::dict out;
  out["found"] = r.found;
  out["path"] = points_array(r.path);
  out["tree_path"] = points_array(r.tree_path);
  out["nodes"] = r.nodes;
  out["steps"] = r.steps;
  out["goal_samples"] = r.goal_samples;
  return out;
}

py::array_t<bool> py_rrt_seed003_free_along(const I8Grid& occupancy,
                                            const py::array_t<double, kInFlags>& segments,
                                            int hitbox_width_cells, int hitbox_length_cells,
                                            int occupied_threshold, bool unknown_is_obstacle) {
  const Shape s = grid_shape(occupancy, "rrt_seed003_free_along", "occupancy");
  if (!(segments.size() == 0 || (segments.ndim() == 2 && segments.shape(1) == 4)))
    fail("rrt_seed003_free_along", "segments must be an (n, 4) array of (x0, y0, x1, y1)");
  const tp::RrtSeed003Params p = params(hitbox_width_cells, hitbox_length_cells,
                                        occupied_threshold, unknown_is_obstacle);
  tp::validate(p, "rrt_seed003_free_along");
  const auto n = static_cast<py::ssize_t>(segments.size() / 4);
  py::array_t<bool> out(n);
  bool* dst = out.mutable_data();
  const double* q = segments.data();
  {
    py::gil_scoped_release release;
    const tp::HitBoxGrid grid(occupancy.data(), s.rows, s.cols, p);
    for (py::ssize_t i = 0; i < n; ++i)
      dst[i] = grid.free_along({q[4 * i], q[4 * i + 1]}, {q[4 * i + 2], q[4 * i + 3]});
  }
  return out;
}

}  // namespace

void register_rrt_seed003(py::module_& m) {
  m.def("rrt_seed003", &py_rrt_seed003, py::arg("occupancy"), py::arg("start"), py::arg("goal"),
        py::arg("seed"), py::arg("goal_fraction"), py::arg("step_cells"),
        py::arg("hitbox_width_cells"), py::arg("hitbox_length_cells"), py::arg("max_steps"),
        py::arg("max_nodes"), py::arg("shortcut"), py::arg("occupied_threshold"),
        py::arg("unknown_is_obstacle"),
        "Seed 003's RRT on ROS int8 occupancy (-1 unknown, 0..100): start, goal (x, y) in cells\n"
        "(x = column, y = row; cell (r, c) spans [c, c + 1) x [r, r + 1)); targets are the goal\n"
        "with probability goal_fraction, else a uniform cell centre (std::mt19937(seed)); the\n"
        "nearest node steps step_cells toward the target and is kept where the axis-aligned\n"
        "hit-box of hitbox_width_cells (x) x hitbox_length_cells (y), centred on it, is free at\n"
        "it and along the connection; the goal joins from within one step; at most max_steps\n"
        "steps and max_nodes nodes; then the two-pointer shortcut (if shortcut). Returns a dict:\n"
        "found, path float (n, 2) cells start ... goal, tree_path (before the shortcut), nodes,\n"
        "steps, goal_samples (steps whose target was the goal); n = 0 when not found. ValueError\n"
        "naming the start or goal when it is off the grid, in an obstacle or its hit-box is not free.");
  m.def("rrt_seed003_free_along", &py_rrt_seed003_free_along, py::arg("occupancy"),
        py::arg("segments"), py::arg("hitbox_width_cells"), py::arg("hitbox_length_cells"),
        py::arg("occupied_threshold"), py::arg("unknown_is_obstacle"),
        "bool (n,): whether rrt_seed003's hit-box stays free (no obstacle square overlapped, on\n"
        "the grid) while its centre moves along each (x0, y0, x1, y1) segment (cells).");
}
