// Control area of turtlebot_recon._native: the dynamic window approach
// (include/turtlebot_recon/dwa.hpp), bound as the class Dwa: built once per controller from
// its settings and the robot, then plan() once per control period. This file only converts
// and checks arguments.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <utility>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/dwa.hpp"

namespace py = pybind11;
namespace tc = turtlebot_recon::control;
using namespace turtlebot_recon::bindings;

namespace {

using XY = std::pair<double, double>;
using XYYaw = std::tuple<double, double, double>;

tc::Dwa make_dwa(double max_linear_mps, double min_linear_mps, double max_angular_radps,
                 double linear_accel_mps2, double angular_accel_radps2, double footprint_length_m,
                 double footprint_width_m, double footprint_offset_x_m, double radius_m,
                 double outline_spacing_m, int linear_samples,
                 int angular_samples, double horizon_s, double dt_s, double margin_m,
                 double clearance_max_m, bool unknown_is_obstacle, int occupied_threshold,
                 double heading_weight, double clearance_weight, double velocity_weight) {
  tc::DwaConfig c;
  c.max_linear_mps = max_linear_mps;
  c.min_linear_mps = min_linear_mps;
  c.max_angular_radps = max_angular_radps;
  c.linear_accel_mps2 = linear_accel_mps2;
  c.angular_accel_radps2 = angular_accel_radps2;
  c.footprint = {footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  c.outline_spacing_m = outline_spacing_m;
  c.linear_samples = linear_samples;
  c.angular_samples = angular_samples;
  c.horizon_s = horizon_s;
  c.dt_s = dt_s;
  c.margin_m = margin_m;
  c.clearance_max_m = clearance_max_m;
  c.unknown_is_obstacle = unknown_is_obstacle;
  c.occupied_threshold = occupied_threshold;
  c.heading_weight = heading_weight;
  c.clearance_weight = clearance_weight;
  c.velocity_weight = velocity_weight;
  try {
    return tc::Dwa(c);
  } catch (const std::invalid_argument& e) {
    fail("Dwa", e.what());
  }
}

bool finite(std::initializer_list<double> values) {
  for (double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

py::dict py_plan(tc::Dwa& dwa, const I8Grid& occupancy, double resolution, XY origin, XYYaw pose,
                 XY velocity, double period_s, XY target, XY goal, double goal_radius_m,
                 double goal_distance_m, const py::array_t<double, kInFlags>& path_ahead) {
  constexpr const char* fn = "Dwa.plan";
  const Shape s = grid_shape(occupancy, fn, "occupancy");
  if (s.rows == 0 || s.cols == 0) fail(fn, "occupancy is empty");
  if (!(std::isfinite(resolution) && resolution > 0)) fail(fn, "resolution must be > 0 m");
  tc::DwaQuery q;
  q.pose = {std::get<0>(pose), std::get<1>(pose), std::get<2>(pose)};
  q.v = velocity.first, q.w = velocity.second;
  q.period_s = period_s;
  q.target_x = target.first, q.target_y = target.second;
  q.goal_x = goal.first, q.goal_y = goal.second;
  q.goal_radius_m = goal_radius_m;
  q.goal_distance_m = goal_distance_m;
  if (!finite({q.pose.x, q.pose.y, q.pose.yaw, origin.first, origin.second}))
    fail(fn, "pose and origin must be finite");
  if (!finite({q.target_x, q.target_y, q.goal_x, q.goal_y, goal_radius_m}))
    fail(fn, "target, goal and goal_radius_m must be finite");
  if (!(std::isfinite(period_s) && period_s > 0)) fail(fn, "period_s must be > 0 s");
  if (std::isnan(goal_distance_m)) fail(fn, "goal_distance_m must not be NaN");
  if (!(path_ahead.size() == 0 || (path_ahead.ndim() == 2 && path_ahead.shape(1) == 3)))
    fail(fn, "path_ahead must be an (n, 3) array of (x, y, yaw)");
  const double* pa = path_ahead.data();
  for (py::ssize_t i = 0; i < path_ahead.size() / 3; ++i) {
    if (!finite({pa[3 * i], pa[3 * i + 1], pa[3 * i + 2]})) fail(fn, "path_ahead must be finite");
    q.path_ahead.push_back({pa[3 * i], pa[3 * i + 1], pa[3 * i + 2]});
  }
  tc::DwaResult r;
  {
    py::gil_scoped_release release;
    r = dwa.plan(occupancy.data(), s.rows, s.cols, resolution, origin.first, origin.second, q);
  }
  const auto n = static_cast<py::ssize_t>(r.arcs.size());
  py::array_t<double> v(n), w(n), score(n), clearance(n);
  py::array_t<double> terms(std::vector<py::ssize_t>{n, 3});
  py::array_t<bool> admissible(n);
  py::array_t<std::int32_t> poses(n);
  auto t = terms.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const tc::DwaArc& a = r.arcs[static_cast<size_t>(i)];
    v.mutable_data()[i] = a.v;
    w.mutable_data()[i] = a.w;
    score.mutable_data()[i] = a.score;
    clearance.mutable_data()[i] = a.clearance_m;
    admissible.mutable_data()[i] = a.admissible;
    poses.mutable_data()[i] = a.poses;
    t(i, 0) = a.heading, t(i, 1) = a.clearance, t(i, 2) = a.velocity;
  }
  py::array_t<double> trajectory(std::vector<py::ssize_t>{0, 3});
  if (r.best >= 0) {
    const tc::DwaArc& b = r.arcs[static_cast<size_t>(r.best)];
    const auto path = dwa.rollout(q.pose, b.v, b.w, b.poses);
    trajectory = py::array_t<double>(std::vector<py::ssize_t>{static_cast<py::ssize_t>(path.size()), 3});
    auto o = trajectory.mutable_unchecked<2>();
    for (size_t k = 0; k < path.size(); ++k) o(k, 0) = path[k].x, o(k, 1) = path[k].y, o(k, 2) = path[k].yaw;
  }
  py::dict d;
  d["best"] = r.best;
  d["clearance_cap_m"] = r.clearance_cap_m;
  d["window"] = py::make_tuple(r.window.v_lo, r.window.v_hi, r.window.w_lo, r.window.w_hi);
  d["v"] = v;
  d["w"] = w;
  d["admissible"] = admissible;
  d["score"] = score;
  d["clearance_m"] = clearance;
  d["terms"] = terms;
  d["poses"] = poses;
  d["trajectory"] = trajectory;
  return d;
}

std::string repr(const tc::Dwa& dwa) {
  const tc::DwaConfig& c = dwa.config();
  std::ostringstream o;
  o << "Dwa(" << c.linear_samples << "x" << c.angular_samples << " samples, horizon "
    << c.horizon_s << " s every " << c.dt_s << " s, v <= " << c.max_linear_mps << " m/s, |w| <= "
    << c.max_angular_radps << " rad/s, weights " << c.heading_weight << "/" << c.clearance_weight
    << "/" << c.velocity_weight << ", " << (c.footprint.round() ? "disc" : "box") << ")";
  return o.str();
}

}  // namespace

void register_dwa(py::module_& m) {
  py::class_<tc::Dwa>(m, "Dwa",
                      "The dynamic window approach (include/turtlebot_recon/dwa.hpp): n_v x n_w\n"
                      "arcs in the window around the measured (v, w), the body checked along each\n"
                      "against a distance field, score alpha heading + beta clearance + gamma velocity.")
      .def(py::init(&make_dwa), py::arg("max_linear_mps"), py::arg("min_linear_mps"),
           py::arg("max_angular_radps"), py::arg("linear_accel_mps2"),
           py::arg("angular_accel_radps2"), py::arg("footprint_length_m"),
           py::arg("footprint_width_m"), py::arg("footprint_offset_x_m"),
           py::arg("radius_m"), py::arg("outline_spacing_m"),
           py::arg("linear_samples"), py::arg("angular_samples"),
           py::arg("horizon_s"), py::arg("dt_s"), py::arg("margin_m"),
           py::arg("clearance_max_m"), py::arg("unknown_is_obstacle"),
           py::arg("occupied_threshold"), py::arg("heading_weight"),
           py::arg("clearance_weight"), py::arg("velocity_weight"))
      .def("plan", &py_plan, py::arg("occupancy"), py::arg("resolution"), py::arg("origin"),
           py::arg("pose"), py::arg("velocity"), py::arg("period_s"), py::arg("target"), py::arg("goal"),
           py::arg("goal_radius_m"), py::arg("goal_distance_m"),
           py::arg("path_ahead"),
           "One DWA step. pose (x, y, yaw) and velocity (v, w) measured, period_s the control\n"
           "period (the window's reach); target: the look-ahead\n"
           "point the heading term aims at; an arc ends at its first pose within goal_radius_m\n"
           "of goal; v <= sqrt(2 a goal_distance_m); clearance scored up to\n"
           "clearance_max_m or the body's least clearance at the (n, 3) poses path_ahead (the\n"
           "plan's). Returns a dict: best (index, -1: no\n"
           "admissible arc), window (v_lo, v_hi, w_lo, w_hi), per arc v, w, admissible, score\n"
           "(-inf inadmissible), clearance_m, terms (heading, clearance, velocity; raw), poses\n"
           "(rolled out, the start included), and trajectory: the best arc's (k, 3) poses.")
      .def("rollout",
           [](const tc::Dwa& dwa, XYYaw pose, double v, double w, int n) {
             const auto path = dwa.rollout({std::get<0>(pose), std::get<1>(pose), std::get<2>(pose)}, v, w, n);
             py::array_t<double> out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(path.size()), 3});
             auto o = out.mutable_unchecked<2>();
             for (size_t k = 0; k < path.size(); ++k) o(k, 0) = path[k].x, o(k, 1) = path[k].y, o(k, 2) = path[k].yaw;
             return out;
           },
           py::arg("pose"), py::arg("v"), py::arg("w"), py::arg("n"),
           "The first n poses (at most steps + 1, the start included) of arc (v, w) from pose.")
      .def_property_readonly("steps", &tc::Dwa::steps, "rollout steps per arc (horizon / dt)")
      .def("__repr__", &repr);
}
