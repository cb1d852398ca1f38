// iLQR tracking for the differential drive (unicycle): the ancillary controller of Tube MPPI.
//
// Model (seed 000's discrete unicycle), state x = (x m, y m, yaw rad), control u = (v m/s, w rad/s):
//   x_{t+1} = x_t + dt (v cos yaw, v sin yaw, w).
// Cost of a control sequence u_0..u_{T-1} from x_0, tracking the references xref_0..xref_T and
// uref_0..uref_{T-1} (the nominal states and controls of MPPI):
//   J = sum_{t<T} [ e_t' Q e_t + du_t' R du_t ] + e_T' Qf e_T,
//   e_t = x_t - xref_t (yaw wrapped to (-pi, pi]),  du_t = u_t - uref_t.
// Control bounds u_min <= u <= u_max are kept exactly: the backward pass solves each step's
// two-control quadratic over the box (the control-limited DDP of Tassa, Mansard, Todorov 2014;
// with two controls the box QP is solved exactly by its interior and edge candidates), and its
// gain rows of the clamped controls are zero.
//
// One iteration (Tassa, Erez, Todorov 2012):
//   1. backward pass  linearise f about the current trajectory (analytic Jacobians A, B);
//                     Q-function with the regularised value Hessian V' + mu I; a non positive
//                     definite Quu raises mu and restarts the pass;
//   2. forward pass   u_t = clamp(ubar_t + alpha k_t + K_t (x_t - xbar_t)) for alpha = 1, 1/2,
//                     1/4, ...; accept the first whose actual decrease is at least
//                     `min_decrease_ratio` of the decrease the quadratic model expects;
//   3. regularisation lowered after an accepted step, raised after a failed line search;
//   4. stop when the relative decrease falls below `tolerance`, at `max_iterations`, or when
//      mu exceeds `mu_max` (no descent direction left).
// The gains returned belong to the returned trajectory (one last backward pass about it), so
// that u = u_t + K_t (x - x_t) is the local feedback policy around it.
//
// Fixed-size Eigen types throughout: a 56-step problem takes a few microseconds per iteration.
#pragma once

#include <Eigen/Core>
#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

// Nested: the sampling controllers' headers share namespace control.
namespace turtlebot_recon::control::ilqr {

using State = Eigen::Vector3d;
using Control = Eigen::Vector2d;
using Gain = Eigen::Matrix<double, 2, 3>;

struct Settings {
  Eigen::Matrix3d Q = Eigen::Vector3d(1.0, 1.0, 0.1).asDiagonal();    // per step, 1/m^2, 1/rad^2
  Eigen::Matrix2d R = Eigen::Vector2d(0.1, 0.01).asDiagonal();        // per step, s^2/m^2, s^2/rad^2
  Eigen::Matrix3d Qf = Eigen::Vector3d(10.0, 10.0, 1.0).asDiagonal(); // terminal
  Control u_min{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  Control u_max{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  int max_iterations = 10;
  double tolerance = 1e-4;          // stop when (J_old - J_new) / J_old falls below this
  double min_decrease_ratio = 1e-4; // line search: actual / expected decrease at least this
  int line_search_steps = 8;        // alpha = 1, 1/2, ..., 2^-(steps-1)
  double mu_init = 0.0;             // regularisation (added to the value Hessian)
  double mu_min = 1e-6;             // below it mu is 0
  double mu_max = 1e10;             // above it the iteration stops
  double mu_factor = 1.6;           // Tassa 2012's Delta_0: the growth of the factor on mu
};

struct Result {
  std::vector<State> states;         // T + 1
  std::vector<Control> controls;     // T
  std::vector<Gain> gains;           // T, about `states` / `controls`
  std::vector<double> cost_history;  // the initial cost, then one per accepted iteration
  int iterations = 0;                // iterations run (accepted or not)
  bool converged = false;            // stopped on `tolerance`
  double mu = 0.0;                   // the regularisation at the end
};

// ---- model -----------------------------------------------------------------------------

inline double wrap_angle(double a) {  // to (-pi, pi]
  constexpr double kPi = 3.14159265358979323846;
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

inline State unicycle_step(const State& x, const Control& u, double dt) {
  return x + dt * State(u(0) * std::cos(x(2)), u(0) * std::sin(x(2)), u(1));
}

// A = df/dx, B = df/du at (x, u).
inline void unicycle_jacobians(const State& x, const Control& u, double dt, Eigen::Matrix3d& A,
                               Eigen::Matrix<double, 3, 2>& B) {
  const double c = std::cos(x(2)), s = std::sin(x(2));
  A.setIdentity();
  A(0, 2) = -dt * u(0) * s;
  A(1, 2) = dt * u(0) * c;
  B << dt * c, 0.0, dt * s, 0.0, 0.0, dt;
}

inline State state_error(const State& x, const State& ref) {
  State e = x - ref;
  e(2) = wrap_angle(e(2));
  return e;
}

inline Control clamp_control(const Control& u, const Settings& s) {
  return u.cwiseMax(s.u_min).cwiseMin(s.u_max);
}

// ---- the solver ------------------------------------------------------------------------

class Tracker {
 public:
  Tracker(double dt, Settings settings) : dt_(dt), s_(std::move(settings)) {
    if (!(std::isfinite(dt) && dt > 0)) throw std::invalid_argument("dt must be > 0 s");
    if (!(s_.u_min.array() <= s_.u_max.array()).all())
      throw std::invalid_argument("u_min must be <= u_max");
    if (s_.max_iterations < 0 || s_.line_search_steps < 1)
      throw std::invalid_argument("max_iterations must be >= 0, line_search_steps >= 1");
    if (!(s_.mu_factor > 1.0)) throw std::invalid_argument("mu_factor must be > 1");
  }

  // Track xref (T + 1 states) and uref (T controls) from x0, starting from u_init (T controls,
  // clamped to the bounds).
  Result solve(const State& x0, const std::vector<State>& xref,
                   const std::vector<Control>& uref, const std::vector<Control>& u_init) {
    const size_t T = uref.size();
    if (xref.size() != T + 1 || u_init.size() != T || T == 0)
      throw std::invalid_argument("need T >= 1 controls, T + 1 reference states, T initial controls");
    xref_ = &xref;
    uref_ = &uref;
    resize(T);
    Result r;
    r.controls.resize(T);
    for (size_t t = 0; t < T; ++t) r.controls[t] = clamp_control(u_init[t], s_);
    r.states.resize(T + 1);
    double cost = rollout(x0, r.controls, r.states);
    r.cost_history.push_back(cost);
    double mu = s_.mu_init, delta = 1.0;

    for (r.iterations = 0; r.iterations < s_.max_iterations;) {
      ++r.iterations;
      // 1. backward pass, raising mu until every Quu is positive definite
      while (!backward_pass(r.states, r.controls, mu)) {
        if (!increase_mu(mu, delta)) break;
      }
      if (mu > s_.mu_max) break;
      // 2. forward pass with a line search over alpha
      bool accepted = false;
      double alpha = 1.0;
      for (int i = 0; i < s_.line_search_steps; ++i, alpha *= 0.5) {
        const double new_cost = forward_pass(x0, r.states, r.controls, alpha);
        const double expected = -(alpha * dv1_ + 0.5 * alpha * alpha * dv2_);
        if (!std::isfinite(new_cost)) continue;
        const double actual = cost - new_cost;
        if (actual > 0 && (expected <= 0 || actual >= s_.min_decrease_ratio * expected)) {
          r.states.swap(x_new_);
          r.controls.swap(u_new_);
          const double relative = actual / std::max(cost, 1e-12);
          cost = new_cost;
          r.cost_history.push_back(cost);
          accepted = true;
          if (relative < s_.tolerance) r.converged = true;
          break;
        }
      }
      // 3. regularisation schedule
      if (accepted) {
        decrease_mu(mu, delta);
        if (r.converged) break;
      } else {
        // no step decreases the cost: at a minimum (a zero expected decrease), or more damping
        if (-(dv1_ + 0.5 * dv2_) < 1e-12 * std::max(cost, 1.0)) {
          r.converged = true;
          break;
        }
        if (!increase_mu(mu, delta)) break;
      }
    }
    // the gains about the returned trajectory
    double mu_k = std::max(mu, 0.0), delta_k = 1.0;
    while (!backward_pass(r.states, r.controls, mu_k)) {
      if (!increase_mu(mu_k, delta_k)) break;
    }
    r.gains = K_;
    r.mu = mu;
    return r;
  }

  // The cost of a state and control sequence against the current references.
  double cost(const std::vector<State>& x, const std::vector<Control>& u) const {
    double J = 0.0;
    const size_t T = u.size();
    for (size_t t = 0; t < T; ++t) {
      const State e = state_error(x[t], (*xref_)[t]);
      const Control du = u[t] - (*uref_)[t];
      J += e.dot(s_.Q * e) + du.dot(s_.R * du);
    }
    const State e = state_error(x[T], (*xref_)[T]);
    return J + e.dot(s_.Qf * e);
  }

 private:
  void resize(size_t T) {
    K_.assign(T, Gain::Zero());
    k_.assign(T, Control::Zero());
    x_new_.resize(T + 1);
    u_new_.resize(T);
  }

  double rollout(const State& x0, const std::vector<Control>& u, std::vector<State>& x) const {
    x[0] = x0;
    for (size_t t = 0; t < u.size(); ++t) x[t + 1] = unicycle_step(x[t], u[t], dt_);
    return cost(x, u);
  }

  // The two-control QP min_k 0.5 k'H k + g'k over lo <= k <= hi (H positive definite): the
  // unconstrained minimum if inside, else the best of the four edges (one control at a bound,
  // the other minimised and clamped). `free` marks the controls not at a bound.
  static Control box_qp(const Eigen::Matrix2d& H, const Control& g, const Control& lo,
                        const Control& hi, bool free[2]) {
    Control k = -H.ldlt().solve(g);
    if ((k.array() >= lo.array()).all() && (k.array() <= hi.array()).all()) {
      free[0] = free[1] = true;
      return k;
    }
    double best = std::numeric_limits<double>::infinity();
    Control best_k = k.cwiseMax(lo).cwiseMin(hi);
    for (int i = 0; i < 2; ++i) {
      const int j = 1 - i;
      for (double b : {lo(i), hi(i)}) {
        if (!std::isfinite(b)) continue;
        Control c;
        c(i) = b;
        c(j) = std::clamp(-(g(j) + H(j, i) * b) / H(j, j), lo(j), hi(j));
        const double v = 0.5 * c.dot(H * c) + g.dot(c);
        if (v < best) {
          best = v;
          best_k = c;
        }
      }
    }
    for (int i = 0; i < 2; ++i)
      free[i] = best_k(i) > lo(i) + 1e-12 && best_k(i) < hi(i) - 1e-12;
    return best_k;
  }

  // Gains k_t, K_t about (x, u) with regularisation mu; false where some Quu is not positive
  // definite. dv1_, dv2_: the expected decrease's terms, sum k'Qu and sum k'Quu k.
  bool backward_pass(const std::vector<State>& x, const std::vector<Control>& u, double mu) {
    const size_t T = u.size();
    const State eT = state_error(x[T], (*xref_)[T]);
    Eigen::Vector3d Vx = 2.0 * s_.Qf * eT;
    Eigen::Matrix3d Vxx = 2.0 * s_.Qf;
    Eigen::Matrix3d A;
    Eigen::Matrix<double, 3, 2> B;
    dv1_ = dv2_ = 0.0;
    for (size_t t = T; t-- > 0;) {
      unicycle_jacobians(x[t], u[t], dt_, A, B);
      const State e = state_error(x[t], (*xref_)[t]);
      const Control du = u[t] - (*uref_)[t];
      const Eigen::Matrix3d Vreg = Vxx + mu * Eigen::Matrix3d::Identity();
      const Eigen::Vector3d Qx = 2.0 * s_.Q * e + A.transpose() * Vx;
      const Control Qu = 2.0 * s_.R * du + B.transpose() * Vx;
      const Eigen::Matrix3d Qxx = 2.0 * s_.Q + A.transpose() * Vxx * A;
      const Eigen::Matrix2d Quu = 2.0 * s_.R + B.transpose() * Vreg * B;
      const Gain Qux = B.transpose() * Vreg * A;
      const Eigen::LLT<Eigen::Matrix2d> llt(Quu);
      if (llt.info() != Eigen::Success) return false;
      // k over the box of the control's room: u_min - u <= k <= u_max - u
      bool free[2];
      const Control k = box_qp(Quu, Qu, s_.u_min - u[t], s_.u_max - u[t], free);
      Gain K = Gain::Zero();
      if (free[0] && free[1]) {
        K = -llt.solve(Qux);
      } else {
        for (int i = 0; i < 2; ++i)
          if (free[i] && !free[1 - i]) K.row(i) = -Qux.row(i) / Quu(i, i);
      }
      k_[t] = k;
      K_[t] = K;
      dv1_ += k.dot(Qu);
      dv2_ += k.dot(Quu * k);
      // value update (the form that stays exact with a regularised or clamped K)
      Vx = Qx + K.transpose() * Quu * k + K.transpose() * Qu + Qux.transpose() * k;
      Vxx = Qxx + K.transpose() * Quu * K + K.transpose() * Qux + Qux.transpose() * K;
      Vxx = 0.5 * (Vxx + Vxx.transpose());
    }
    return true;
  }

  double forward_pass(const State& x0, const std::vector<State>& x, const std::vector<Control>& u,
                      double alpha) {
    x_new_[0] = x0;
    for (size_t t = 0; t < u.size(); ++t) {
      u_new_[t] = clamp_control(u[t] + alpha * k_[t] + K_[t] * state_error(x_new_[t], x[t]), s_);
      x_new_[t + 1] = unicycle_step(x_new_[t], u_new_[t], dt_);
    }
    return cost(x_new_, u_new_);
  }

  // Tassa 2012's schedule: the factor delta grows (shrinks) geometrically by mu_factor.
  bool increase_mu(double& mu, double& delta) const {
    delta = std::max(s_.mu_factor, delta * s_.mu_factor);
    mu = std::max(s_.mu_min, mu * delta);
    return mu <= s_.mu_max;
  }
  void decrease_mu(double& mu, double& delta) const {
    delta = std::min(1.0 / s_.mu_factor, delta / s_.mu_factor);
    mu = mu * delta > s_.mu_min ? mu * delta : 0.0;
  }

  double dt_;
  Settings s_;
  const std::vector<State>* xref_ = nullptr;
  const std::vector<Control>* uref_ = nullptr;
  std::vector<Gain> K_;
  std::vector<Control> k_;
  std::vector<State> x_new_;
  std::vector<Control> u_new_;
  double dv1_ = 0.0, dv2_ = 0.0;
};

}  // namespace turtlebot_recon::control::ilqr
