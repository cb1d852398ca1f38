// iLQR tracking for the differential drive (unicycle): the ancillary controller of Tube MPPI.
//
// Model (seed 000's discrete unicycle), state x = (x m, y m, yaw rad), control u = (v m/s, w rad/s):
//   x_{t+1} = x_t + dt (v cos yaw, v sin yaw, w).
// Cost of a control sequence u_0..u_{T-1} from x_0, tracking the references xref_0..xref_T and
// uref_0..uref_{T-1} (the nominal states and controls of MPPI):
//   J = sum_{t<T} [ e_t' Q e_t + du_t' R du_t + c_t' S c_t ] + e_T' Qf e_T,
//   e_t = x_t - xref_t (yaw wrapped to (-pi, pi]),  du_t = u_t - uref_t,
//   c_t = u_t - u_{t-1}, the change of the command (u_{-1}: the command before, `u_prev`; without
//   one the sum of c_t starts at t = 1).
// The change couples neighbouring controls; the solver carries the previous control as two more
// states, X = (x, y, yaw, p_v, p_w) with p_{t+1} = u_t (the usual augmentation), so the gains
// are 2 x 5: u = u_t + K_t (x - x_t) + P_t (p - p_t). With S = 0, P_t = 0 and nothing changes.
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
// that u = u_t + K_t (x - x_t) is the local feedback policy around it (their state part: with
// S > 0 the policy also has P_t (p - p_t), not returned).
//
// Fixed-size Eigen types throughout: a 56-step problem takes a few microseconds per iteration.
#pragma once

#include <Eigen/Core>
#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

// Nested: the sampling controllers' headers share namespace control.
namespace turtlebot_recon::control::ilqr {

using State = Eigen::Vector3d;
using Control = Eigen::Vector2d;
using Gain = Eigen::Matrix<double, 2, 3>;
using Aug = Eigen::Matrix<double, 5, 1>;          // (x, y, yaw, the previous v, w)
using AugGain = Eigen::Matrix<double, 2, 5>;
using AugMatrix = Eigen::Matrix<double, 5, 5>;

struct Settings {
  Eigen::Matrix3d Q = Eigen::Vector3d(1.0, 1.0, 0.1).asDiagonal();    // per step, 1/m^2, 1/rad^2
  Eigen::Matrix2d R = Eigen::Vector2d(0.1, 0.01).asDiagonal();        // per step, s^2/m^2, s^2/rad^2
  Eigen::Matrix3d Qf = Eigen::Vector3d(10.0, 10.0, 1.0).asDiagonal(); // terminal
  Eigen::Matrix2d S = Eigen::Matrix2d::Zero();                        // per step, on u_t - u_{t-1}
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
  std::vector<Gain> gains;           // T, about `states` / `controls` (the state part: K_t)
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
  // clamped to the bounds); u_prev: the command before u_0 (for S; none: no change cost at t = 0).
  Result solve(const State& x0, const std::vector<State>& xref,
               const std::vector<Control>& uref, const std::vector<Control>& u_init,
               const std::optional<Control>& u_prev = std::nullopt) {
    const size_t T = uref.size();
    if (xref.size() != T + 1 || u_init.size() != T || T == 0)
      throw std::invalid_argument("need T >= 1 controls, T + 1 reference states, T initial controls");
    xref_ = &xref;
    uref_ = &uref;
    u_prev_ = u_prev;
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
    r.gains.resize(T);
    for (size_t t = 0; t < T; ++t) r.gains[t] = K_[t].leftCols<3>();
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
      const Control c = change(u, t);
      J += e.dot(s_.Q * e) + du.dot(s_.R * du) + c.dot(s_.S * c);
    }
    const State e = state_error(x[T], (*xref_)[T]);
    return J + e.dot(s_.Qf * e);
  }

 private:
  // c_t = u_t - u_{t-1} (zero at t = 0 without u_prev).
  Control change(const std::vector<Control>& u, size_t t) const {
    if (t > 0) return u[t] - u[t - 1];
    return u_prev_ ? Control(u[0] - *u_prev_) : Control::Zero();
  }
  // Whether c_t is a cost term (S acts on it): every t but the first without u_prev.
  bool has_change(size_t t) const { return t > 0 || u_prev_.has_value(); }

  void resize(size_t T) {
    K_.assign(T, AugGain::Zero());
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
    // the augmented state X = (x, p): X_{t+1} = (f(x_t, u_t), u_t), so A5 = [A 0; 0 0] and
    // B5 = [B; I]; the change cost c' S c with c = u - p adds -2 S c to Qp, 2 S c to Qu, 2 S to
    // Qpp and Quu, and -2 S to Qup.
    const State eT = state_error(x[T], (*xref_)[T]);
    Aug Vx = Aug::Zero();
    AugMatrix Vxx = AugMatrix::Zero();
    Vx.head<3>() = 2.0 * s_.Qf * eT;
    Vxx.topLeftCorner<3, 3>() = 2.0 * s_.Qf;
    Eigen::Matrix3d A3;
    Eigen::Matrix<double, 3, 2> B3;
    AugMatrix A = AugMatrix::Zero();
    Eigen::Matrix<double, 5, 2> B = Eigen::Matrix<double, 5, 2>::Zero();
    B.bottomRows<2>().setIdentity();
    dv1_ = dv2_ = 0.0;
    for (size_t t = T; t-- > 0;) {
      unicycle_jacobians(x[t], u[t], dt_, A3, B3);
      A.topLeftCorner<3, 3>() = A3;
      B.topRows<3>() = B3;
      const State e = state_error(x[t], (*xref_)[t]);
      const Control du = u[t] - (*uref_)[t];
      const Eigen::Matrix2d S = has_change(t) ? s_.S : Eigen::Matrix2d::Zero();
      const Control c = change(u, t);
      const AugMatrix Vreg = Vxx + mu * AugMatrix::Identity();
      Aug Qx = A.transpose() * Vx;
      Qx.head<3>() += 2.0 * s_.Q * e;
      Qx.tail<2>() -= 2.0 * S * c;
      const Control Qu = 2.0 * s_.R * du + 2.0 * S * c + B.transpose() * Vx;
      AugMatrix Qxx = A.transpose() * Vxx * A;
      Qxx.topLeftCorner<3, 3>() += 2.0 * s_.Q;
      Qxx.bottomRightCorner<2, 2>() += 2.0 * S;
      const Eigen::Matrix2d Quu = 2.0 * (s_.R + S) + B.transpose() * Vreg * B;
      AugGain Qux = B.transpose() * Vreg * A;
      Qux.rightCols<2>() -= 2.0 * S;
      const Eigen::LLT<Eigen::Matrix2d> llt(Quu);
      if (llt.info() != Eigen::Success) return false;
      // k over the box of the control's room: u_min - u <= k <= u_max - u
      bool free[2];
      const Control k = box_qp(Quu, Qu, s_.u_min - u[t], s_.u_max - u[t], free);
      AugGain K = AugGain::Zero();
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
      Aug dX;
      dX.head<3>() = state_error(x_new_[t], x[t]);
      dX.tail<2>() = t > 0 ? Control(u_new_[t - 1] - u[t - 1]) : Control::Zero();
      u_new_[t] = clamp_control(u[t] + alpha * k_[t] + K_[t] * dX, s_);
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
  std::optional<Control> u_prev_;
  std::vector<AugGain> K_;
  std::vector<Control> k_;
  std::vector<State> x_new_;
  std::vector<Control> u_new_;
  double dv1_ = 0.0, dv2_ = 0.0;
};

}  // namespace turtlebot_recon::control::ilqr
