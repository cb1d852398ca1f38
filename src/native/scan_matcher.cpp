// SLAM area of turtlebot_recon._native: the scan matcher of the front end. The algorithm lives
// in scan_matcher.hpp (no pybind11 there); this file only converts and checks the arguments,
// releases the GIL and serialises calls on one matcher (its buffers are reused).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstddef>
#include <iomanip>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/scan_matcher.hpp"

namespace py = pybind11;
namespace ts = turtlebot_recon::slam;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

constexpr const char* kFn = "ScanMatcher.match";
using DoubleArray = py::array_t<double, kInFlags>;

// A matcher and the lock that keeps two threads (the GIL released) off its buffers.
struct LockedMatcher {
  explicit LockedMatcher(const ts::MatcherParams& p) : matcher(p) {}
  ts::ScanMatcher matcher;
  std::mutex mutex;
};

// The number n of an (n, 2) float point array, all finite; ValueError naming `name` otherwise.
std::size_t point_count(const DoubleArray& a, const char* name) {
  if (!(a.ndim() == 2 && a.shape(1) == 2) && !(a.size() == 0 && a.ndim() == 1)) {
    std::string shape;
    for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
    if (a.ndim() == 1) shape += ",";
    fail(kFn, std::string(name) + " must be an (n, 2) array of (x, y), got shape (" + shape + ")");
  }
  const std::size_t n = static_cast<std::size_t>(a.size() / 2);
  const double* d = a.data();
  for (std::size_t i = 0; i < 2 * n; ++i)
    if (!std::isfinite(d[i]))
      fail(kFn, std::string(name) + " must be finite, row " + std::to_string(i / 2) + " is (" +
                    std::to_string(d[i - i % 2]) + ", " + std::to_string(d[i - i % 2 + 1]) + ")");
  return n;
}

ts::Pose2 guess_pose(const py::object& value) {
  std::vector<double> q;
  try {
    for (const py::handle item : value) q.push_back(item.cast<double>());
  } catch (const std::exception&) {
    fail(kFn, "guess must be a sequence of 3 numbers (x m, y m, yaw rad), got " +
                  std::string(py::repr(value)));
  }
  if (q.size() != 3 || !std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2]))
    fail(kFn, "guess must be 3 finite numbers (x m, y m, yaw rad), got " +
                  std::string(py::repr(value)));
  return {q[0], q[1], q[2]};
}

ts::MatchResult py_match(LockedMatcher& self, const DoubleArray& points,
                         const DoubleArray& reference, const py::object& guess,
                         const std::optional<DoubleArray>& views) {
  const std::size_t n = point_count(points, "points");
  const std::size_t m = point_count(reference, "reference");
  const ts::Pose2 g = guess_pose(guess);
  if (views && point_count(*views, "views") != m)
    fail(kFn, "views must have one row per reference point (" + std::to_string(m) + "), got " +
                  std::to_string(views->size() / 2));
  const double* v = views ? views->data() : nullptr;
  py::gil_scoped_release release;
  std::lock_guard<std::mutex> lock(self.mutex);
  return self.matcher.match(points.data(), static_cast<int>(n), reference.data(),
                            static_cast<int>(m), g, v);
}

py::array_t<double> covariance(const ts::MatchResult& r) {
  py::array_t<double> out({3, 3});
  auto o = out.mutable_unchecked<2>();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) o(i, j) = r.covariance(i, j);
  return out;
}

std::string repr(const ts::MatchResult& r) {
  std::ostringstream s;
  s << std::setprecision(4);
  if (!r.ok) return "ScanMatch(ok=False, failure='" + r.failure + "')";
  s << "ScanMatch(pose=(" << r.pose.x << ", " << r.pose.y << ", " << r.pose.yaw
    << "), score=" << r.score << ", response=" << r.response
    << ", degenerate=" << (r.degenerate ? "True" : "False") << ", points_used=" << r.points_used
    << ", iterations=" << r.iterations << ")";
  return s.str();
}

}  // namespace

void register_slam(py::module_& m) {
  py::class_<ts::MatchResult>(m, "ScanMatch", "Result of ScanMatcher.match (see scan_matcher.hpp).")
      .def_readonly("ok", &ts::MatchResult::ok)
      .def_readonly("failure", &ts::MatchResult::failure, "why not ok; empty when ok")
      .def_property_readonly("pose", [](const ts::MatchResult& r) {
             return py::make_tuple(r.pose.x, r.pose.y, r.pose.yaw);
           }, "(x m, y m, yaw rad) of the scan frame in the reference frame")
      .def_property_readonly("covariance", &covariance,
                             "(3, 3) covariance of (x, y, yaw), body frame (GTSAM Pose2)")
      .def_readonly("score", &ts::MatchResult::score,
                    "fraction of scan points with a residual <= inlier_m")
      .def_readonly("response", &ts::MatchResult::response,
                    "normalised correlative response of the coarse pose, [0, 1]")
      .def_readonly("degenerate", &ts::MatchResult::degenerate)
      .def_property_readonly("degenerate_direction", [](const ts::MatchResult& r) {
             return py::make_tuple(r.degenerate_direction.x(), r.degenerate_direction.y());
           }, "unit (x, y) in the reference frame; (0, 0) unless degenerate")
      .def_readonly("points_used", &ts::MatchResult::points_used)
      .def_readonly("conditioning", &ts::MatchResult::conditioning,
                    "l_min / l_max of the translational information at the solution")
      .def_readonly("iterations", &ts::MatchResult::iterations)
      .def("__repr__", &repr);

  py::class_<LockedMatcher>(
      m, "ScanMatcher",
      "2-D scan-to-submap matcher: Olson's correlative search, then point-to-line ICP\n"
      "(include/turtlebot_recon/scan_matcher.hpp). Lengths in m, angles in rad.")
      .def(py::init([](double search_xy_m, double search_yaw_rad, double grid_resolution_m,
                       double coarse_resolution_m, double coarse_yaw_step_rad, double sigma_m,
                       int icp_iterations, double max_correspondence_m, double normal_radius_m,
                       double huber_m, double inlier_m, int min_points, double degeneracy_ratio,
                       double degenerate_std_m, double max_range_m) {
             ts::MatcherParams p;
             p.search_xy_m = search_xy_m;
             p.search_yaw_rad = search_yaw_rad;
             p.grid_resolution_m = grid_resolution_m;
             p.coarse_resolution_m = coarse_resolution_m;
             p.coarse_yaw_step_rad = coarse_yaw_step_rad;
             p.sigma_m = sigma_m;
             p.icp_iterations = icp_iterations;
             p.max_correspondence_m = max_correspondence_m;
             p.normal_radius_m = normal_radius_m;
             p.huber_m = huber_m;
             p.inlier_m = inlier_m;
             p.min_points = min_points;
             p.degeneracy_ratio = degeneracy_ratio;
             p.degenerate_std_m = degenerate_std_m;
             p.max_range_m = max_range_m;
             return std::make_unique<LockedMatcher>(p);
           }),
           py::arg("search_xy_m"), py::arg("search_yaw_rad"),
           py::arg("grid_resolution_m"),
           py::arg("coarse_resolution_m"),
           py::arg("coarse_yaw_step_rad"), py::arg("sigma_m"),
           py::arg("icp_iterations"),
           py::arg("max_correspondence_m"),
           py::arg("normal_radius_m"), py::arg("huber_m"),
           py::arg("inlier_m"), py::arg("min_points"),
           py::arg("degeneracy_ratio"),
           py::arg("degenerate_std_m"), py::arg("max_range_m"))
      .def("match", &py_match, py::arg("points"), py::arg("reference"), py::arg("guess"),
           py::arg("views") = py::none(),
           "Match points ((n, 2) float64, the scan's frame) to reference ((m, 2) float64, the\n"
           "map frame) from guess (x, y, yaw); views: None or (m, 2), where each reference\n"
           "point was seen from (map frame): lines are then centred per face, and a scan\n"
           "point pairs with the face its ray meets. Returns a ScanMatch; ok=False with a\n"
           "failure reason when a side has too few points or too few correspondences remain.\n"
           "ValueError for a wrong shape or a non-finite value. Releases the GIL.")
      .def("__repr__", [](const LockedMatcher& s) {
             const ts::MatcherParams& p = s.matcher.params();
             std::ostringstream o;
             o << "ScanMatcher(search_xy_m=" << p.search_xy_m << ", search_yaw_rad="
               << p.search_yaw_rad << ", grid_resolution_m=" << p.grid_resolution_m << ")";
             return o.str();
           });
}
