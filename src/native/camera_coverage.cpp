// Perception area of turtlebot_recon._native: camera coverage, the wall cells a forward camera
// has seen well enough to read a tag. The algorithm lives in camera_coverage.hpp (no pybind11
// there); this file only converts the arguments, checks them and releases the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/camera_coverage.hpp"

namespace py = pybind11;
namespace tc = turtlebot_recon::perception;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

constexpr const char* kFn = "camera_coverage";

// `n` numbers from a tuple, list or 1-D array; ValueError naming `name` otherwise.
std::vector<double> numbers(const py::object& value, std::size_t n, const char* name) {
  const std::string expected = std::string(name) + " must be a sequence of " +
                               std::to_string(n) + " numbers";
  if (!py::isinstance<py::sequence>(value) && !py::isinstance<py::array>(value))
    fail(kFn, expected + ", got " + std::string(py::str(py::type::of(value).attr("__name__"))));
  std::vector<double> out;
  try {
    for (const py::handle item : value) out.push_back(item.cast<double>());
  } catch (const py::cast_error&) {
    fail(kFn, expected + ", got " + std::string(py::repr(value)));
  }
  if (out.size() != n) fail(kFn, expected + ", got " + std::to_string(out.size()));
  return out;
}

// The caller's `seen` array, written in place: it must be exactly uint8, C-contiguous,
// writable and of the occupancy's shape (any conversion would write to a copy instead).
py::array checked_seen(const py::object& value, Shape s) {
  if (!py::isinstance<py::array>(value))
    fail(kFn, "seen must be a numpy uint8 array or None, got " +
                  std::string(py::str(py::type::of(value).attr("__name__"))));
  py::array seen = py::reinterpret_borrow<py::array>(value);
  if (!seen.dtype().is(py::dtype::of<std::uint8_t>()))
    fail(kFn, "seen must have dtype uint8, got " + std::string(py::str(seen.dtype())));
  if (seen.ndim() != 2 || seen.shape(0) != s.rows || seen.shape(1) != s.cols)
    fail(kFn, "seen must have the occupancy's shape (" + std::to_string(s.rows) + ", " +
                  std::to_string(s.cols) + ")");
  if (!(seen.flags() & py::array::c_style) || !seen.writeable())
    fail(kFn, "seen must be a C-contiguous, writable array (it is updated in place)");
  return seen;
}

py::array py_camera_coverage(const I8Grid& occupancy, double resolution, const py::object& origin,
                             const py::object& pose, double hfov_rad, double max_range_m,
                             double max_incidence_rad, int occupied_threshold, int rays,
                             const py::object& seen) {
  const Shape s = grid_shape(occupancy, kFn, "occupancy");
  const std::vector<double> o = numbers(origin, 2, "origin");
  const std::vector<double> q = numbers(pose, 3, "pose");
  const tc::CameraPose camera{q[0], q[1], q[2]};
  const tc::CoverageParams p{resolution, o[0],      o[1],              hfov_rad,
                             max_range_m, max_incidence_rad, occupied_threshold, rays};
  tc::validate(camera, p);
  py::array out = seen.is_none()
                      ? py::array(py::array_t<std::uint8_t>({s.rows, s.cols}))
                      : checked_seen(seen, s);
  auto* dst = static_cast<std::uint8_t*>(out.mutable_data());
  if (seen.is_none()) std::fill(dst, dst + static_cast<std::size_t>(s.rows) * s.cols, 0);
  {
    py::gil_scoped_release release;
    tc::camera_coverage(occupancy.data(), s.rows, s.cols, camera, p, dst);
  }
  return out;
}

}  // namespace

void register_perception(py::module_& m) {
  m.def("camera_coverage", &py_camera_coverage, py::arg("occupancy"), py::arg("resolution"),
        py::arg("origin"), py::arg("pose"), py::arg("hfov_rad"), py::arg("max_range_m"),
        py::arg("max_incidence_rad"), py::arg("occupied_threshold"),
        py::arg("rays"), py::arg("seen") = py::none(),
        "Camera coverage: uint8 (rows, cols), 1 on every wall cell of `occupancy` (int8\n"
        "(rows, cols), ROS values, row 0 = smallest y; a wall is >= occupied_threshold) that a\n"
        "ray of the camera at pose (x m, y m, yaw rad, grid frame) hits first within hfov_rad\n"
        "(centred on yaw) and max_range_m, meeting the wall's surface at an incidence angle <=\n"
        "max_incidence_rad (a cell with no clear wall direction: any angle). Rays stop at the\n"
        "first wall, at unknown cells (< 0) and at the grid's edge. origin: (x, y) m of cell\n"
        "(0, 0)'s corner; resolution: m per cell. rays: number of rays over the field of view\n"
        "(0: at most half a cell apart at max range, and close enough that they hit every cell\n"
        "of a straight wall face seen within max_incidence_rad). seen: uint8 (rows, cols) or\n"
        "None; when given, the hits are OR-ed into it in place and it is returned.\n"
        "ValueError naming the argument on bad input. See include/turtlebot_recon/\n"
        "camera_coverage.hpp.");
}
