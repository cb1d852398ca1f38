// Exploration area of turtlebot_recon._native: information gain of frontier viewpoints by
// ray casting. The algorithm lives in visibility.hpp (no pybind11 there); this file only
// converts numpy arrays, checks shapes and releases the GIL around the loop.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <stdexcept>
#include <string>

#include "turtlebot_recon/visibility.hpp"

namespace py = pybind11;
namespace te = turtlebot_recon::exploration;

namespace {

constexpr auto kInFlags = py::array::c_style | py::array::forcecast;
using I8Grid = py::array_t<std::int8_t, kInFlags>;
using I32Array = py::array_t<std::int32_t, kInFlags>;

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("visible_unknown: " + what);  // ValueError in Python
}

py::array_t<std::int32_t> py_visible_unknown(const I8Grid& occupancy, const I32Array& cells,
                                             double radius_cells, int beams,
                                             int free_threshold) {
  if (occupancy.ndim() != 2)
    fail("occupancy must be a 2-D (rows, cols) array, got " + std::to_string(occupancy.ndim()) +
         "-D");
  // An empty query may come as shape (0,) as well as (0, 2).
  if (!(cells.size() == 0 || (cells.ndim() == 2 && cells.shape(1) == 2)))
    fail("cells must be an (n, 2) array of (row, col)");
  const int rows = static_cast<int>(occupancy.shape(0));
  const int cols = static_cast<int>(occupancy.shape(1));
  const auto n = static_cast<size_t>(cells.size() / 2);
  const te::VisibilityParams p{radius_cells, beams, free_threshold};
  py::array_t<std::int32_t> out(static_cast<py::ssize_t>(n));
  std::int32_t* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    te::visible_unknown(occupancy.data(), rows, cols, cells.data(), n, p, dst);
  }
  return out;
}

}  // namespace

void register_exploration(py::module_& m) {
  m.def("visible_unknown", &py_visible_unknown, py::arg("occupancy"), py::arg("cells"),
        py::arg("radius_cells"), py::arg("beams") = 180, py::arg("free_threshold") = 25,
        "Information gain: for each query cell of `cells` (int32 (n, 2) of (row, col)), the\n"
        "number of distinct unknown (< 0) cells of `occupancy` (int8 (rows, cols), ROS values)\n"
        "that `beams` Bresenham rays, evenly spread over 360 degrees, pass over within\n"
        "radius_cells (centre to centre) before an occupied cell (0..100, > free_threshold)\n"
        "or the grid's edge stops them. Unknown cells let rays through; the query cell never\n"
        "stops them. Returns int32 (n,). ValueError if a query cell is off the grid.");
}
