// Control area of turtlebot_recon._native: the MPPI optimizer (include/turtlebot_recon/mppi/),
// bound as one class. This file only converts and checks arguments; the GIL is released
// around the C++ work.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/mppi/optimizer.hpp"

namespace py = pybind11;
namespace mp = turtlebot_recon::mppi;
namespace tc = turtlebot_recon::control;
using namespace turtlebot_recon::bindings;

namespace {

// The config keys (MppiSettings' names, config/mppi.yaml) and where each goes.
using Setter = std::function<void(mp::MppiConfig&, const py::handle&, const std::string&)>;

Setter real(double mp::OptimizerSettings::*f) {
  return [f](mp::MppiConfig& c, const py::handle& v, const std::string&) {
    c.optimizer.*f = v.cast<double>();
  };
}
template <class P>
Setter real(P mp::MppiConfig::*part, double P::*f) {
  return [part, f](mp::MppiConfig& c, const py::handle& v, const std::string&) {
    (c.*part).*f = v.cast<double>();
  };
}
Setter integer(int mp::OptimizerSettings::*f) {
  return [f](mp::MppiConfig& c, const py::handle& v, const std::string& k) {
    if (!py::isinstance<py::int_>(v) || py::isinstance<py::bool_>(v))
      fail("MppiOptimizer", k + " must be an integer");
    c.optimizer.*f = v.cast<int>();
  };
}

Setter flag(bool mp::OptimizerSettings::*f) {
  return [f](mp::MppiConfig& c, const py::handle& v, const std::string& k) {
    if (!py::isinstance<py::bool_>(v)) fail("MppiOptimizer", k + " must be true or false");
    c.optimizer.*f = v.cast<bool>();
  };
}
Setter flag(mp::MotionLimits mp::MppiConfig::*part, bool mp::MotionLimits::*f) {
  return [part, f](mp::MppiConfig& c, const py::handle& v, const std::string& k) {
    if (!py::isinstance<py::bool_>(v)) fail("MppiOptimizer", k + " must be true or false");
    (c.*part).*f = v.cast<bool>();
  };
}

const std::map<std::string, Setter>& config_keys() {
  using C = mp::MppiConfig;
  using O = mp::OptimizerSettings;
  static const std::map<std::string, Setter> keys = {
      {"batch_size", integer(&O::batch_size)},
      {"time_steps", integer(&O::time_steps)},
      {"model_dt_s", real(&O::model_dt_s)},
      {"temperature", real(&O::temperature)},
      {"noise_std_v_mps", real(&O::noise_std_v_mps)},
      {"noise_std_w_radps", real(&O::noise_std_w_radps)},
      {"noise_knot_steps", integer(&O::noise_knot_steps)},
      {"goal_region_m", real(&O::goal_region_m)},
      {"smooth", flag(&O::smooth)},
      {"outline_spacing_m", real(&O::outline_spacing_m)},
      {"path_resolution_m", real(&O::path_resolution_m)},
      {"threads", integer(&O::threads)},
      {"min_linear_mps", real(&C::limits, &mp::MotionLimits::min_linear_mps)},
      {"clamp_velocity", flag(&C::limits, &mp::MotionLimits::clamp_velocity)},
      {"goal_distance_weight", real(&C::goal_distance, &mp::GoalDistanceParams::weight)},
      {"goal_heading_weight", real(&C::goal_heading, &mp::GoalHeadingParams::weight)},
      {"goal_heading_threshold_m", real(&C::goal_heading, &mp::GoalHeadingParams::threshold_m)},
      {"path_follow_weight", real(&C::path_follow, &mp::PathFollowParams::weight)},
      {"path_align_weight", real(&C::path_align, &mp::PathAlignParams::weight)},
      {"obstacle_weight", real(&C::obstacle, &mp::ObstacleParams::weight)},
      {"obstacle_band_m", real(&C::obstacle, &mp::ObstacleParams::band_m)},
      {"collision_margin_m", real(&C::obstacle, &mp::ObstacleParams::margin_m)},
      {"collision_cost", real(&C::obstacle, &mp::ObstacleParams::collision_cost)},
      {"velocity_limits_weight", real(&C::velocity_limits, &mp::VelocityLimitsParams::weight)},
      {"prefer_forward_weight", real(&C::prefer_forward, &mp::PreferForwardParams::weight)},
  };
  return keys;
}

std::vector<std::string> py_mppi_config_keys() {
  std::vector<std::string> out;
  for (const auto& kv : config_keys()) out.push_back(kv.first);
  return out;
}

// The motion model alone, for tests against a reference: requested (K, T, 2) speeds made
// feasible from `velocity`, and the poses after each step from `pose`.
py::tuple py_mppi_motion_model(std::array<double, 3> pose, std::array<double, 2> velocity,
                               const py::array_t<double, kInFlags>& requested, double dt_s,
                               double min_linear_mps, double max_linear_mps,
                               double max_angular_radps, double max_linear_accel_mps2,
                               double max_angular_accel_radps2, bool clamp_velocity) {
  constexpr const char* fn = "mppi_motion_model";
  if (!(requested.ndim() == 3 && requested.shape(2) == 2 && requested.shape(0) >= 1 &&
        requested.shape(1) >= 1))
    fail(fn, "requested must be a (K, T, 2) array of (v, w)");
  const auto K = requested.shape(0), T = requested.shape(1);
  mp::Array v(K, T), w(K, T), x, y, yaw, cos_yaw, sin_yaw;
  auto r = requested.unchecked<3>();
  for (py::ssize_t k = 0; k < K; ++k)
    for (py::ssize_t t = 0; t < T; ++t) {
      v(k, t) = static_cast<float>(r(k, t, 0));
      w(k, t) = static_cast<float>(r(k, t, 1));
    }
  try {
    const mp::MotionLimits limits{min_linear_mps, max_linear_mps, max_angular_radps,
                                  max_linear_accel_mps2, max_angular_accel_radps2, clamp_velocity};
    const mp::DiffDriveModel model(limits, dt_s);
    model.constrain(v, w, {velocity[0], velocity[1]});
    model.integrate(v, w, {pose[0], pose[1], pose[2]}, x, y, yaw, cos_yaw, sin_yaw);
  } catch (const std::invalid_argument& e) {
    fail(fn, e.what());
  }
  py::array_t<double> controls({K, T, py::ssize_t{2}}), poses({K, T, py::ssize_t{3}});
  auto c = controls.mutable_unchecked<3>();
  auto p = poses.mutable_unchecked<3>();
  for (py::ssize_t k = 0; k < K; ++k)
    for (py::ssize_t t = 0; t < T; ++t) {
      c(k, t, 0) = v(k, t);
      c(k, t, 1) = w(k, t);
      p(k, t, 0) = x(k, t);
      p(k, t, 1) = y(k, t);
      p(k, t, 2) = yaw(k, t);
    }
  return py::make_tuple(controls, poses);
}

class PyMppi {
 public:
  PyMppi(const py::dict& config, double max_linear_mps, double max_angular_radps,
         double max_linear_accel_mps2, double max_angular_accel_radps2,
         double footprint_length_m, double footprint_width_m, double footprint_offset_x_m,
         double radius_m, std::uint32_t seed) {
    constexpr const char* fn = "MppiOptimizer";
    mp::MppiConfig cfg;
    for (const auto& item : config) {
      const std::string key = py::str(item.first);
      const auto it = config_keys().find(key);
      if (it == config_keys().end()) fail(fn, "unknown config key '" + key + "'");
      try {
        it->second(cfg, item.second, key);
      } catch (const py::cast_error&) {
        fail(fn, key + " has the wrong type");
      }
    }
    cfg.limits.max_linear_mps = max_linear_mps;
    cfg.limits.max_angular_radps = max_angular_radps;
    cfg.limits.max_linear_accel_mps2 = max_linear_accel_mps2;
    cfg.limits.max_angular_accel_radps2 = max_angular_accel_radps2;
    cfg.optimizer.seed = seed;
    const tc::Footprint fp{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
    try {
      opt_.emplace(cfg, fp);
    } catch (const std::invalid_argument& e) {
      fail(fn, e.what());
    }
  }

  void reset() { opt_->reset(); }
  void carry(double v, double w) { opt_->carry(static_cast<float>(v), static_cast<float>(w)); }

  void set_map(const I8Grid& occupancy, double resolution, std::pair<double, double> origin,
               int occupied_threshold) {
    constexpr const char* fn = "MppiOptimizer.set_map";
    const Shape s = grid_shape(occupancy, fn, "occupancy");
    if (!(std::isfinite(origin.first) && std::isfinite(origin.second)))
      fail(fn, "origin must be finite");
    const std::int8_t* occ = occupancy.data();
    try {
      py::gil_scoped_release release;
      opt_->set_map(tc::DistanceField(occ, s.rows, s.cols, resolution, origin.first,
                                      origin.second, occupied_threshold),
                    origin.first, origin.second);
    } catch (const std::invalid_argument& e) {
      fail(fn, e.what());
    }
  }

  py::dict optimize(std::array<double, 3> pose, std::array<double, 2> velocity,
                    const py::array_t<double, kInFlags>& path, std::array<double, 2> goal,
                    std::optional<double> goal_yaw, int shift_steps) {
    constexpr const char* fn = "MppiOptimizer.optimize";
    if (!opt_->has_map()) fail(fn, "no map: call set_map first");
    for (double v : {pose[0], pose[1], pose[2], velocity[0], velocity[1], goal[0], goal[1]})
      if (!std::isfinite(v)) fail(fn, "pose, velocity and goal must be finite");
    if (!(path.ndim() == 2 && path.shape(1) == 2 && path.shape(0) >= 1))
      fail(fn, "path must be an (n >= 1, 2) array of (x, y)");
    const int n = static_cast<int>(path.shape(0));
    const double* p = path.data();
    for (int i = 0; i < 2 * n; ++i)
      if (!std::isfinite(p[i])) fail(fn, "path must be finite");
    if (shift_steps < 0) fail(fn, "shift_steps must be >= 0");
    const mp::Pose start{pose[0], pose[1], pose[2]};
    const mp::Speeds now{velocity[0], velocity[1]};
    const mp::Goal g{goal[0], goal[1], goal_yaw.value_or(NAN)};
    mp::Plan plan;
    {
      py::gil_scoped_release release;
      plan = opt_->optimize(start, now, p, n, g, shift_steps);
    }
    py::dict out;
    py::array_t<double> controls({plan.controls.rows(), Eigen::Index{2}});
    auto c = controls.mutable_unchecked<2>();
    for (Eigen::Index t = 0; t < plan.controls.rows(); ++t)
      for (int j = 0; j < 2; ++j) c(t, j) = plan.controls(t, j);
    out["controls"] = controls;
    py::array_t<double> states({plan.states.rows(), Eigen::Index{3}});
    auto st = states.mutable_unchecked<2>();
    for (Eigen::Index t = 0; t < plan.states.rows(); ++t)
      for (int j = 0; j < 3; ++j) st(t, j) = plan.states(t, j);
    out["states"] = states;
    out["min_cost"] = plan.min_cost;
    out["colliding"] = plan.colliding;
    out["all_collide"] = plan.all_collide;
    out["collides"] = plan.collides;
    return out;
  }

  py::array_t<double> rollouts(int count) const {
    const int K = opt_->batch_size();
    const int n = std::max(0, std::min(count, K));
    const int T = opt_->config().optimizer.time_steps;
    py::array_t<double> out({py::ssize_t{n}, py::ssize_t{T}, py::ssize_t{3}});
    auto o = out.mutable_unchecked<3>();
    for (int i = 0; i < n; ++i) {
      const int k = n > 1 ? static_cast<int>(static_cast<long>(i) * (K - 1) / (n - 1)) : 0;
      const Eigen::MatrixX3d r = opt_->rollout(k);
      for (int t = 0; t < T; ++t)
        for (int j = 0; j < 3; ++j) o(i, t, j) = r(t, j);
    }
    return out;
  }

  py::array_t<float> costs() const {
    const Eigen::ArrayXf& c = opt_->costs();
    py::array_t<float> out(c.size());
    std::copy(c.data(), c.data() + c.size(), out.mutable_data());
    return out;
  }

  double reach_m() const { return opt_->reach_m(); }
  bool has_map() const { return opt_->has_map(); }

 private:
  std::optional<mp::Optimizer> opt_;
};

}  // namespace

void register_mppi(py::module_& m) {
  m.def("mppi_motion_model", &py_mppi_motion_model, py::arg("pose"), py::arg("velocity"),
        py::arg("requested"), py::arg("dt_s"), py::arg("min_linear_mps"),
        py::arg("max_linear_mps"), py::arg("max_angular_radps"),
        py::arg("max_linear_accel_mps2"), py::arg("max_angular_accel_radps2"),
        py::arg("clamp_velocity"),
        "MPPI's motion model alone (mppi/motion_model.hpp): the requested (K, T, 2) speeds\n"
        "made feasible from velocity (v, w), and the (K, T, 3) poses after each step from pose.");
  m.def("mppi_config_keys", &py_mppi_config_keys,
        "The keys MppiOptimizer's config takes (MppiSettings' fields that reach C++).");
  py::class_<PyMppi>(m, "MppiOptimizer",
                     "MPPI (include/turtlebot_recon/mppi/optimizer.hpp): sampled rollouts of a\n"
                     "differential drive with the robot's limits, scored by critics, softmax-\n"
                     "weighted, smoothed, warm-started. Deterministic for a seed.")
      .def(py::init<const py::dict&, double, double, double, double, double, double, double,
                    double, std::uint32_t>(),
           py::arg("config"), py::arg("max_linear_mps"), py::arg("max_angular_radps"),
           py::arg("max_linear_accel_mps2"), py::arg("max_angular_accel_radps2"),
           py::arg("footprint_length_m"), py::arg("footprint_width_m"),
           py::arg("footprint_offset_x_m"), py::arg("radius_m"), py::arg("seed"))
      .def("reset", &PyMppi::reset,
           "Zero control sequence and history; the noise restarts from the seed.")
      .def("carry", &PyMppi::carry, py::arg("v"), py::arg("w"),
           "Hold the control sequence and the history at (v m/s, w rad/s): the warm start of "
           "a robot already driving at them.")
      .def("set_map", &PyMppi::set_map, py::arg("occupancy"), py::arg("resolution"),
           py::arg("origin"), py::arg("occupied_threshold"),
           "Build the distance field of the int8 occupancy's obstacle cells (>= threshold).")
      .def("optimize", &PyMppi::optimize, py::arg("pose"), py::arg("velocity"), py::arg("path"),
           py::arg("goal"), py::arg("goal_yaw") = py::none(), py::arg("shift_steps"),
           "One MPPI iteration from pose (x, y, yaw) at velocity (v, w) along the local path\n"
           "(n, 2) (from its point nearest the pose) to goal (x, y) [goal_yaw rad]. Returns a\n"
           "dict: controls (T, 2), states (T + 1, 3), min_cost, colliding, all_collide, collides.")
      .def("rollouts", &PyMppi::rollouts, py::arg("count"),
           "(count, T, 3) poses of rollouts spread over the last iteration's batch.")
      .def("costs", &PyMppi::costs, "(K,) the last iteration's rollout costs.")
      .def_property_readonly("reach_m", &PyMppi::reach_m)
      .def_property_readonly("has_map", &PyMppi::has_map);
}
