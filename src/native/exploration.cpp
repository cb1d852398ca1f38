// Exploration area of turtlebot_recon._native: information gain of frontier viewpoints by
// ray casting, and the line of sight of a set of viewpoints (for the evaluator). The
// algorithms live in visibility.hpp (no pybind11 there); this file only converts numpy
// arrays, checks shapes and releases the GIL around the loops.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>

#include "numpy_args.hpp"
#include "turtlebot_recon/visibility.hpp"

namespace py = pybind11;
namespace te = turtlebot_recon::exploration;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

py::array_t<std::int32_t> py_visible_unknown(const I8Grid& occupancy, const I32Array& cells,
                                             double radius_cells, int beams,
                                             int free_threshold) {
  const Shape s = grid_shape(occupancy, "visible_unknown", "occupancy");
  const std::size_t n = cell_count(cells, "visible_unknown", "cells");
  const te::VisibilityParams p{radius_cells, beams, free_threshold};
  py::array_t<std::int32_t> out(static_cast<py::ssize_t>(n));
  std::int32_t* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    te::visible_unknown(occupancy.data(), s.rows, s.cols, cells.data(), n, p, dst);
  }
  return out;
}

py::array_t<bool> py_visible_cells(const U8Grid& blocking, const I32Array& points,
                                   double radius_cells, int beams) {
  const Shape s = grid_shape(blocking, "visible_cells", "blocking");
  const std::size_t n = cell_count(points, "visible_cells", "points");
  py::array_t<bool> seen({static_cast<py::ssize_t>(s.rows), static_cast<py::ssize_t>(s.cols)});
  bool* dst = seen.mutable_data();
  {
    py::gil_scoped_release release;
    te::visible_cells(blocking.data(), s.rows, s.cols, points.data(), n, radius_cells, beams,
                      dst);
  }
  return seen;
}

}  // namespace

void register_exploration(py::module_& m) {
  m.def("visible_unknown", &py_visible_unknown, py::arg("occupancy"), py::arg("cells"),
        py::arg("radius_cells"), py::arg("beams"), py::arg("free_threshold"),
        "Information gain: for each query cell of `cells` (int32 (n, 2) of (row, col)), the\n"
        "number of distinct unknown (< 0) cells of `occupancy` (int8 (rows, cols), ROS values)\n"
        "that `beams` Bresenham rays, evenly spread over 360 degrees, pass over within\n"
        "radius_cells (centre to centre) before an occupied cell (0..100, > free_threshold)\n"
        "or the grid's edge stops them. Unknown cells let rays through; the query cell never\n"
        "stops them. Returns int32 (n,). ValueError if a query cell is off the grid.");
  m.def("visible_cells", &py_visible_cells, py::arg("blocking"), py::arg("points"),
        py::arg("radius_cells"), py::arg("beams"),
        "Line of sight: bool (rows, cols), true on every cell that some of `beams` Bresenham\n"
        "rays (the rays of visible_unknown) from some viewpoint of `points` (int32 (n, 2) of\n"
        "(row, col)) reaches within radius_cells (centre to centre) before a blocking cell\n"
        "(`blocking` uint8 (rows, cols) != 0) or the grid's edge stops it. Blocking cells are\n"
        "never seen; a viewpoint's own cell does not stop its rays. ValueError if a point is\n"
        "off the grid.");
}
