// Control area of turtlebot_recon._native, iLQR: the unicycle tracker of Tube MPPI
// (include/turtlebot_recon/ilqr.hpp). This file only converts and checks arguments and
// releases the GIL around the solver.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "numpy_args.hpp"
#include "turtlebot_recon/ilqr.hpp"

namespace py = pybind11;
namespace il = turtlebot_recon::control::ilqr;
using namespace turtlebot_recon::bindings;

namespace {

constexpr const char* kFn = "ilqr_track";
using F64Array = py::array_t<double, kInFlags>;

// The rows of an (n, dim) array as fixed-size vectors; ValueError unless finite and shaped.
template <int Dim>
std::vector<Eigen::Matrix<double, Dim, 1>> rows_of(const F64Array& a, const char* name,
                                                   py::ssize_t n) {
  if (!(a.ndim() == 2 && a.shape(0) == n && a.shape(1) == Dim))
    fail(kFn, std::string(name) + " must be an (" + std::to_string(n) + ", " +
                  std::to_string(Dim) + ") array");
  std::vector<Eigen::Matrix<double, Dim, 1>> out(static_cast<size_t>(n));
  const double* p = a.data();
  for (py::ssize_t i = 0; i < n; ++i)
    for (int j = 0; j < Dim; ++j) {
      const double v = p[i * Dim + j];
      if (!std::isfinite(v)) fail(kFn, std::string(name) + " must be finite");
      out[static_cast<size_t>(i)](j) = v;
    }
  return out;
}

template <int Dim>
Eigen::Matrix<double, Dim, 1> vector_of(const std::vector<double>& v, const char* name,
                                        bool weights) {
  if (v.size() != Dim)
    fail(kFn, std::string(name) + " must have " + std::to_string(Dim) + " values");
  Eigen::Matrix<double, Dim, 1> out;
  for (int j = 0; j < Dim; ++j) {
    if (std::isnan(v[j]) || (weights && !(std::isfinite(v[j]) && v[j] >= 0)))
      fail(kFn, std::string(name) + (weights ? " must be finite and >= 0" : " must not be NaN"));
    out(j) = v[j];
  }
  return out;
}

std::string repr(const il::Result& r) {
  std::ostringstream s;
  s << "IlqrResult(steps=" << r.controls.size() << ", iterations=" << r.iterations
    << ", converged=" << (r.converged ? "True" : "False") << ", cost=" << r.cost_history.front()
    << " -> " << r.cost_history.back() << ", mu=" << r.mu << ")";
  return s.str();
}

il::Result py_ilqr_track(const F64Array& x0, const F64Array& x_ref, const F64Array& u_ref,
                         const std::optional<F64Array>& u_init, double dt,
                         const std::vector<double>& q, const std::vector<double>& r,
                         const std::vector<double>& qf, const std::vector<double>& r_change,
                         const std::optional<F64Array>& u_prev, const std::vector<double>& u_min,
                         const std::vector<double>& u_max, int max_iterations) {
  if (!(u_ref.ndim() == 2 && u_ref.shape(0) >= 1 && u_ref.shape(1) == 2))
    fail(kFn, "u_ref must be a (T, 2) array of (v m/s, w rad/s), T >= 1");
  const py::ssize_t T = u_ref.shape(0);
  if (!(x0.size() == 3)) fail(kFn, "x0 must be (x m, y m, yaw rad)");
  const il::State start(x0.data()[0], x0.data()[1], x0.data()[2]);
  if (!start.allFinite()) fail(kFn, "x0 must be finite");
  const auto xr = rows_of<3>(x_ref, "x_ref", T + 1);
  const auto ur = rows_of<2>(u_ref, "u_ref", T);
  const auto ui = u_init ? rows_of<2>(*u_init, "u_init", T) : ur;
  il::Settings s;
  s.Q = vector_of<3>(q, "q", true).asDiagonal();
  s.R = vector_of<2>(r, "r", true).asDiagonal();
  s.Qf = vector_of<3>(qf, "qf", true).asDiagonal();
  s.S = vector_of<2>(r_change, "r_change", true).asDiagonal();
  std::optional<il::Control> previous;
  if (u_prev) {
    if (u_prev->size() != 2) fail(kFn, "u_prev must be (v m/s, w rad/s)");
    previous = il::Control(u_prev->data()[0], u_prev->data()[1]);
    if (!previous->allFinite()) fail(kFn, "u_prev must be finite");
  }
  s.u_min = vector_of<2>(u_min, "u_min", false);
  s.u_max = vector_of<2>(u_max, "u_max", false);
  s.max_iterations = max_iterations;   // the solver's own tolerances: ilqr.hpp's Settings
  try {
    py::gil_scoped_release release;
    il::Tracker tracker(dt, s);
    return tracker.solve(start, xr, ur, ui, previous);
  } catch (const std::invalid_argument& e) {
    fail(kFn, e.what());
  }
}

template <int Rows, int Cols>
py::array_t<double> stack(const std::vector<Eigen::Matrix<double, Rows, Cols>>& v) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(v.size()), Rows};
  if (Cols > 1) shape.push_back(Cols);
  py::array_t<double> out(shape);
  double* dst = out.mutable_data();
  for (const auto& m : v)
    for (int i = 0; i < Rows; ++i)
      for (int j = 0; j < Cols; ++j) *dst++ = m(i, j);
  return out;
}

}  // namespace

void register_ilqr(py::module_& m) {
  py::class_<il::Result>(m, "IlqrResult", "Result of ilqr_track (see ilqr.hpp).")
      .def_property_readonly("states", [](const il::Result& r) { return stack(r.states); },
                             "(T + 1, 3) states (x m, y m, yaw rad) from x0")
      .def_property_readonly("controls", [](const il::Result& r) { return stack(r.controls); },
                             "(T, 2) controls (v m/s, w rad/s), within the bounds")
      .def_property_readonly("gains", [](const il::Result& r) { return stack(r.gains); },
                             "(T, 2, 3) feedback gains K_t about states/controls: "
                             "u = controls[t] + K_t (x - states[t]) (yaw difference wrapped)")
      .def_property_readonly("cost_history", [](const il::Result& r) {
        return py::array_t<double>(static_cast<py::ssize_t>(r.cost_history.size()),
                                   r.cost_history.data());
      }, "the initial cost, then the cost after each accepted iteration")
      .def_readonly("iterations", &il::Result::iterations)
      .def_readonly("converged", &il::Result::converged)
      .def_readonly("mu", &il::Result::mu, "the regularisation at the end")
      .def("__repr__", &repr);
  m.def("ilqr_track", &py_ilqr_track, py::arg("x0"), py::arg("x_ref"), py::arg("u_ref"),
        py::arg("u_init") = py::none(), py::arg("dt"), py::arg("q"), py::arg("r"), py::arg("qf"),
        py::arg("r_change"), py::arg("u_prev") = py::none(), py::arg("u_min"), py::arg("u_max"),
        py::arg("max_iterations"),
        "iLQR tracking for the unicycle x' = x + dt (v cos yaw, v sin yaw, w) (ilqr.hpp): from\n"
        "x0, the T controls within [u_min, u_max] minimising\n"
        "sum e'Qe + du'R du + c'S c + e_T'Qf e_T against x_ref (T + 1, 3) and u_ref (T, 2),\n"
        "starting from u_init (default u_ref); c_t = u_t - u_{t-1}, u_{-1} = u_prev (none: no\n"
        "change cost at t = 0). q, r, qf, r_change: the diagonals of Q, R, Qf, S (per step); the\n"
        "line search and regularisation follow ilqr.hpp's Settings.\n"
        "Returns an IlqrResult.");
}
