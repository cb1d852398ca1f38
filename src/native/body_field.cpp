// Control area of turtlebot_recon._native, shared part: the body against a distance field
// (include/turtlebot_recon/body_field.hpp), bound for tests and for Python-side checks of the
// sampling controllers' obstacle cost. This file only converts and checks arguments.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdint>
#include <utility>

#include "numpy_args.hpp"
#include "turtlebot_recon/body_field.hpp"

namespace py = pybind11;
namespace tc = turtlebot_recon::control;
using namespace turtlebot_recon::bindings;

namespace {

py::array_t<double> py_body_field_clearance(const I8Grid& occupancy, double resolution,
                                            std::pair<double, double> origin,
                                            const py::array_t<double, kInFlags>& poses,
                                            double footprint_length_m, double footprint_width_m,
                                            double footprint_offset_x_m, double radius_m,
                                            double spacing_m, double max_m,
                                            int occupied_threshold) {
  constexpr const char* fn = "body_field_clearance";
  const Shape s = grid_shape(occupancy, fn, "occupancy");
  if (!(poses.size() == 0 || (poses.ndim() == 2 && poses.shape(1) == 3)))
    fail(fn, "poses must be an (n, 3) array of (x, y, yaw)");
  if (!(std::isfinite(resolution) && resolution > 0)) fail(fn, "resolution must be > 0 m");
  const tc::Footprint fp{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  const auto n = static_cast<py::ssize_t>(poses.size() / 3);
  py::array_t<double> out(n);
  double* dst = out.mutable_data();
  const double* p = poses.data();
  const std::int8_t* occ = occupancy.data();
  try {
    py::gil_scoped_release release;
    const tc::BodyOutline body = tc::outline_body(fp, spacing_m);
    const tc::DistanceField field(occ, s.rows, s.cols, resolution, origin.first, origin.second,
                                  occupied_threshold);
    for (py::ssize_t i = 0; i < n; ++i)
      dst[i] = tc::body_clearance(field, body, p[3 * i], p[3 * i + 1], p[3 * i + 2], max_m);
  } catch (const std::invalid_argument& e) {
    fail(fn, e.what());
  }
  return out;
}

}  // namespace

void register_body_field(py::module_& m) {
  m.def("body_field_clearance", &py_body_field_clearance, py::arg("occupancy"),
        py::arg("resolution"), py::arg("origin"), py::arg("poses"),
        py::arg("footprint_length_m"), py::arg("footprint_width_m"),
        py::arg("footprint_offset_x_m"), py::arg("radius_m"), py::arg("spacing_m"), py::arg("max_m"),
        py::arg("occupied_threshold"),
        "Clearance (m, capped at max_m) of the body at each (x, y, yaw) pose from the distance\n"
        "field of the occupancy's obstacle cells (body_field.hpp; a box by its outline sampled\n"
        "every spacing_m): the sampling controllers' obstacle test. Negative where it overlaps.");
}
