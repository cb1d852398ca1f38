// Sampling area of turtlebot_recon._native: OMPL's planners over the oriented footprint
// (include/turtlebot_recon/sampling_planner.hpp says the model), and their binding.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <ompl/base/PlannerData.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/goals/GoalStates.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/samplers/InformedStateSampler.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/rrt/InformedRRTstar.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>

#include "numpy_args.hpp"
#include "turtlebot_recon/body_field.hpp"
#include "turtlebot_recon/sampling_planner.hpp"

namespace py = pybind11;
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace turtlebot_recon::planning {
namespace {

using Pose = std::array<double, 3>;
enum class Drive { kBlocked, kForward, kBackward };

// Exact (std::remainder): OMPL asserts that an SO(2) value lies within [-pi, pi] to one
// epsilon, and a - 2 pi floor(...) misses that by rounding (an abort in RRT-Connect's solve).
double wrap(double a) { return std::remainder(a, 2.0 * kPi); }
// The planners evaluate distances millions of times a second; std::hypot's care for overflow
// is not needed in a building.
double norm(double dx, double dy) { return std::sqrt(dx * dx + dy * dy); }

// OMPL's SO(2) holds [-pi, pi).
double so2(double a) {
  const double w = wrap(a);
  return w >= kPi ? w - 2.0 * kPi : w;
}

// Turn in place, drive forward, turn in place: which poses it passes and what it costs.
class TurnDriveModel {
 public:
  TurnDriveModel(const std::int8_t* occupancy, int rows, int cols, double res,
                 const Footprint& fp, const SamplingRequest& rq)
      : occ_(occupancy), rows_(rows), cols_(cols), res_(res), fp_(fp), margin_(rq.margin_m),
        turn_margin_(rq.turn_margin_m), k_(rq.turn_cost_m_per_rad),
        reverse_(rq.reverse_cost_factor),
        threshold_(rq.occupied_threshold),
        field_(occupancy, rows, cols, res, 0.0, 0.0, rq.occupied_threshold),
        body_(control::outline_body(fp, 0.5 * res)), reach_(body_.radius_m) {
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c)
        if (known_free(r, c) && field_.cell(r, c) >= fp.radius_m + turn_margin_)
          turn_spots_.push_back({(c + 0.5) * res, (r + 0.5) * res});
  }

  // Cell centres where the turning disc (radius_m about base_footprint) keeps turn_margin_m
  // off every obstacle: the robot turns there at will (for a round robot: where it fits).
  const std::vector<std::array<double, 2>>& turn_spots() const { return turn_spots_; }

  // Poses on the line a robot at (x, y, yaw) drives along without turning (sign +1: ahead of
  // it, the start's way out; -1: behind it, a goal's way in), every half cell as far as the
  // footprint fits, at that yaw. A robot that cannot turn where it starts (or ends) reaches
  // the first place where it can only along this line.
  // How many it added.
  int add_line_spots(double x, double y, double yaw, int sign) {
    const double ux = sign * std::cos(yaw), uy = sign * std::sin(yaw);
    int n = 0;
    for (double t = 0.5 * res_;; t += 0.5 * res_, ++n) {
      const double px = x + ux * t, py = y + uy * t;
      if (!pose_clear(px, py, yaw)) break;
      line_spots_.push_back({px, py, yaw});
    }
    return n;
  }
  // Whether the robot turns in place at will at (x, y) (half a cell to spare).
  bool turnable(double x, double y) const {
    return field_.at(x, y) >= fp_.radius_m + turn_margin_ + 0.5 * res_;
  }
  const std::vector<Pose>& line_spots() const { return line_spots_; }

  // The centre on a known free cell and the footprint `margin` off every obstacle.
  bool pose_clear(double x, double y, double yaw) const { return pose_clear(x, y, yaw, margin_); }
  bool pose_clear(double x, double y, double yaw, double margin) const {
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(yaw))) return false;
    if (!known_free(static_cast<int>(std::floor(y / res_)), static_cast<int>(std::floor(x / res_))))
      return false;
    // Far from obstacles the field answers: its values may run up to about half a cell long
    // (centre-to-centre distances, interpolated), so one cell of slack at base_footprint; along
    // a box's outline (points half a cell apart: a corner poking between two comes up to a
    // quarter cell nearer) half a cell and a quarter.
    if (field_.at(x, y) - reach_ >= margin + res_) return true;
    if (!fp_.round() &&
        control::body_clearance(field_, body_, x, y, yaw, margin + res_) >= margin + 0.75 * res_)
      return true;
    auto is_obstacle = [this](int rr, int cc) {
      if (rr < 0 || rr >= rows_ || cc < 0 || cc >= cols_) return true;
      return occ_[static_cast<size_t>(rr) * cols_ + cc] >= threshold_;
    };
    return footprint_clear_at(fp_, margin, res_, x, y, yaw, is_obstacle);
  }

  // Turning in place at (x, y) from `from` to `to` the short way, with the lattice's
  // turn_margin_m: the body's farthest point moves at most half a cell between checks. A
  // round robot's turn sweeps nothing new.
  // A half turn has no short way: which way the follower turns is a rounding's choice (pi or
  // -pi), so both must be clear (bench-plan found a box path whose half turn at the start was
  // clear one way and not the other).
  bool turn_clear(double x, double y, double from, double to) const {
    const double delta = wrap(to - from);
    if (fp_.round()) return pose_clear(x, y, to);
    if (std::fabs(delta) > kPi - 1e-6) return sweep_clear(x, y, from, kPi) && sweep_clear(x, y, from, -kPi);
    return sweep_clear(x, y, from, delta);
  }
  // Turning in place at (x, y) from `from` by `delta` rad, checked every half cell of the body's
  // farthest point's arc.
  bool sweep_clear(double x, double y, double from, double delta) const {
    const int n = std::max(1, static_cast<int>(std::ceil(std::fabs(delta) * reach_ / (0.5 * res_))));
    for (int i = 1; i < n; ++i)
      if (!pose_clear(x, y, from + delta * i / n, turn_margin_)) return false;
    return pose_clear(x, y, from + delta);
  }

  // Driving straight from (x1, y1) to (x2, y2) at `yaw`, checked every half cell.
  bool drive_clear(double x1, double y1, double x2, double y2, double yaw) const {
    const int n = std::max(1, static_cast<int>(std::ceil(norm(x2 - x1, y2 - y1) / (0.5 * res_))));
    for (int i = 1; i <= n; ++i)
      if (!pose_clear(x1 + (x2 - x1) * i / n, y1 + (y2 - y1) * i / n, yaw)) return false;
    return true;
  }

  // The heading held driving a -> b: the segment's direction forward, its opposite backward.
  static double held(const Pose& a, const Pose& b, bool backward) {
    const double dir = std::atan2(b[1] - a[1], b[0] - a[0]);
    return backward ? dir + kPi : dir;
  }

  // Turn at a to the held heading, drive to b, turn to b's yaw; clear all the way.
  bool motion_clear(const Pose& a, const Pose& b, bool backward) const {
    if (norm(b[0] - a[0], b[1] - a[1]) < 1e-9) return turn_clear(a[0], a[1], a[2], b[2]);
    const double h = held(a, b, backward);
    return turn_clear(a[0], a[1], a[2], h) && drive_clear(a[0], a[1], b[0], b[1], h) &&
           turn_clear(b[0], b[1], h, b[2]);
  }
  // Forward where that is clear, else backward where the robot may back (reverse_cost_factor > 0).
  Drive clear_drive(const Pose& a, const Pose& b) const {
    if (motion_clear(a, b, false)) return Drive::kForward;
    if (reverse_ > 0 && motion_clear(a, b, true)) return Drive::kBackward;
    return Drive::kBlocked;
  }
  // A motion backward a -> b sweeps what one forward b -> a does: either is clear or neither.
  bool symmetric() const { return reverse_ > 0; }

  // {metres driven, radians turned}
  static std::pair<double, double> motion(const Pose& a, const Pose& b, bool backward) {
    const double d = norm(b[0] - a[0], b[1] - a[1]);
    if (d < 1e-9) return {0.0, std::fabs(wrap(b[2] - a[2]))};
    const double h = held(a, b, backward);
    return {d, std::fabs(wrap(h - a[2])) + std::fabs(wrap(b[2] - h))};
  }
  double cost(const Pose& a, const Pose& b, bool backward) const {
    const auto [driven, turned] = motion(a, b, backward);
    return driven * (backward ? reverse_ : 1.0) + k_ * turned;
  }
  // The cost the planners see: the cheaper way (which way is clear is the validator's answer).
  double cost(const Pose& a, const Pose& b) const {
    const double forward = cost(a, b, false);
    return reverse_ > 0 ? std::min(forward, cost(a, b, true)) : forward;
  }
  double reverse_factor() const { return reverse_; }
  double turn_cost() const { return k_; }

 private:
  bool known_free(int r, int c) const {
    if (r < 0 || r >= rows_ || c < 0 || c >= cols_) return false;
    const std::int8_t v = occ_[static_cast<size_t>(r) * cols_ + c];
    return v >= 0 && v < threshold_;
  }

  const std::int8_t* occ_;
  int rows_, cols_;
  double res_;
  Footprint fp_;
  double margin_, turn_margin_, k_, reverse_;
  int threshold_;
  control::DistanceField field_;
  control::BodyOutline body_;  // the box's outline every half cell, for the field's answer
  double reach_;  // the body's farthest point from base_footprint
  std::vector<std::array<double, 2>> turn_spots_;
  std::vector<Pose> line_spots_;
};

// 45 % of the samples at the centre of a cell where the robot can turn, at a uniform yaw; 10 %
// on the start's or a goal's line at its heading (TurnDriveModel::add_line_spots); the other
// 45 % uniform over the space. A box robot turns in place only where its turning disc fits,
// in a corridor of a maze a band a few centimetres wide about the centre line, and leaves a
// start (reaches a goal) off that band only straight along its heading; uniform samples
// almost never land on either, so a path round a corner is almost never found.
class TurnSpotSampler : public ob::StateSampler {
 public:
  TurnSpotSampler(const ob::StateSpace* space, const TurnDriveModel& model)
      : ob::StateSampler(space), model_(model), uniform_(space->allocDefaultStateSampler()) {}
  void sampleUniform(ob::State* state) override {
    const double u = rng_.uniform01();
    auto* se2 = state->as<ob::SE2StateSpace::StateType>();
    const auto& lines = model_.line_spots();
    const auto& spots = model_.turn_spots();
    if (u < 0.1 && !lines.empty()) {
      const Pose& p = lines[pick(lines.size())];
      se2->setXY(p[0], p[1]);
      se2->setYaw(so2(p[2]));
    } else if (u < 0.55 && !spots.empty()) {
      const auto& p = spots[pick(spots.size())];
      se2->setXY(p[0], p[1]);
      se2->setYaw(rng_.uniformReal(-kPi, kPi));
    } else {
      uniform_->sampleUniform(state);
    }
  }
  void sampleUniformNear(ob::State* state, const ob::State* near, double distance) override {
    uniform_->sampleUniformNear(state, near, distance);
  }
  void sampleGaussian(ob::State* state, const ob::State* mean, double std_dev) override {
    uniform_->sampleGaussian(state, mean, std_dev);
  }

 private:
  size_t pick(size_t n) { return static_cast<size_t>(rng_.uniformInt(0, static_cast<int>(n) - 1)); }

  const TurnDriveModel& model_;
  ob::StateSamplerPtr uniform_;
};

// Informed RRT*'s and BIT*'s sampler: TurnSpotSampler's samples whose heuristic solution cost
// (OMPL's: cost-to-come heuristic + cost-to-go) beats the best cost so far, by rejection
// (OMPL's direct ellipse sampler would draw its own uniform samples instead). After
// kTries misses (an informed set a sliver of the map; BIT* allows 2^32 - 1 tries, which hung
// a solve for minutes) the last sample stands, as an uninformed one.
class TurnSpotInformedSampler : public ob::InformedSampler {
 public:
  static constexpr unsigned int kTries = 200;
  TurnSpotInformedSampler(const ob::ProblemDefinitionPtr& pdef, unsigned int max_calls)
      : ob::InformedSampler(pdef, max_calls), sampler_(space_->allocStateSampler()) {}
  bool sampleUniform(ob::State* state, const ob::Cost& max_cost) override {
    return sampleUniform(state, opt_->infiniteCost(), max_cost, false);
  }
  bool sampleUniform(ob::State* state, const ob::Cost& min_cost, const ob::Cost& max_cost) override {
    return sampleUniform(state, min_cost, max_cost, true);
  }
  bool hasInformedMeasure() const override { return false; }
  double getInformedMeasure(const ob::Cost&) const override { return space_->getMeasure(); }

 private:
  bool sampleUniform(ob::State* state, const ob::Cost& min_cost, const ob::Cost& max_cost, bool floor) {
    for (unsigned int i = 0; i < std::min(numIters_, kTries); ++i) {
      sampler_->sampleUniform(state);
      const ob::Cost c = heuristicSolnCost(state);
      if (opt_->isCostBetterThan(c, max_cost) && !(floor && opt_->isCostBetterThan(c, min_cost))) return true;
    }
    return true;
  }

  ob::StateSamplerPtr sampler_;
};

Pose pose_of(const ob::State* s) {
  const auto* se2 = s->as<ob::SE2StateSpace::StateType>();
  return {se2->getX(), se2->getY(), se2->getYaw()};
}

// SE(2) with TurnDriveModel's motions: not the same both ways; and a state part of the way
// from one to another lies on the segment's axis, facing along it the way nearer `from`'s
// yaw, so that it is reached from `from` (a start tree's step) or reaches it (a goal tree's,
// RRT-Connect's) without turning, forward or backward, in a corridor where no turn fits.
class ForwardSe2Space : public ob::SE2StateSpace {
 public:
  bool hasSymmetricInterpolate() const override { return false; }
  void interpolate(const ob::State* from, const ob::State* to, double t, ob::State* state) const override {
    if (t <= 0.0 || t >= 1.0) return copyState(state, t <= 0.0 ? from : to);
    const Pose a = pose_of(from), b = pose_of(to);
    auto* se2 = state->as<StateType>();
    se2->setXY(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
    if (norm(b[0] - a[0], b[1] - a[1]) < 1e-9) return se2->setYaw(so2(a[2] + t * wrap(b[2] - a[2])));
    const double axis = std::atan2(b[1] - a[1], b[0] - a[0]);
    se2->setYaw(so2(std::fabs(wrap(axis - a[2])) <= 0.5 * kPi ? axis : axis + kPi));
  }
};

// Directed trees ask for the motion s1 -> s2. An undirected roadmap (PRM*) may drive an edge
// either way: a robot that may back can (a backward motion sweeps what the forward one the
// other way does); one that may not needs an edge clear both ways, but for the start's edges
// (driven away from it) and a goal's (driven into it), which only one way need be.
class TurnDriveValidator : public ob::MotionValidator {
 public:
  TurnDriveValidator(const ob::SpaceInformationPtr& si, const TurnDriveModel& model,
                     bool undirected, const Pose& start, const std::vector<Pose>& goals)
      : ob::MotionValidator(si), model_(model), undirected_(undirected), start_(start),
        goals_(goals) {}
  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const Pose a = pose_of(s1), b = pose_of(s2);
    auto clear = [this](const Pose& p, const Pose& q) { return model_.clear_drive(p, q) != Drive::kBlocked; };
    bool ok;
    if (!undirected_ || model_.symmetric()) ok = clear(a, b);
    else if (a == start_ || is_goal(b)) ok = clear(a, b);
    else if (b == start_ || is_goal(a)) ok = clear(b, a);
    else ok = clear(a, b) && clear(b, a);
    ok ? ++valid_ : ++invalid_;
    return ok;
  }
  // Planners that keep part of a motion get none of it: the last valid state is the first.
  bool checkMotion(const ob::State* s1, const ob::State* s2,
                   std::pair<ob::State*, double>& last_valid) const override {
    if (checkMotion(s1, s2)) return true;
    if (last_valid.first != nullptr) si_->copyState(last_valid.first, s1);
    last_valid.second = 0.0;
    return false;
  }

 private:
  bool is_goal(const Pose& p) const { return std::find(goals_.begin(), goals_.end(), p) != goals_.end(); }

  const TurnDriveModel& model_;
  bool undirected_;
  Pose start_;
  std::vector<Pose> goals_;
};

class TurnDriveObjective : public ob::PathLengthOptimizationObjective {
 public:
  TurnDriveObjective(const ob::SpaceInformationPtr& si, const TurnDriveModel& model)
      : ob::PathLengthOptimizationObjective(si), model_(model) {
    description_ = "metres driven + turn cost";
  }
  ob::Cost motionCost(const ob::State* s1, const ob::State* s2) const override {
    return ob::Cost(model_.cost(pose_of(s1), pose_of(s2)));
  }
  // |dp| + k |dyaw| (the space's distance): a lower bound of any path's cost.
  ob::Cost motionCostHeuristic(const ob::State* s1, const ob::State* s2) const override {
    return ob::Cost(si_->distance(s1, s2));
  }
  bool isSymmetric() const override { return false; }
  ob::InformedSamplerPtr allocInformedStateSampler(const ob::ProblemDefinitionPtr& pdef,
                                                   unsigned int max_calls) const override {
    return std::make_shared<TurnSpotInformedSampler>(pdef, max_calls);
  }

 private:
  const TurnDriveModel& model_;
};

// The trees' extension step: 1 m of driving (OMPL's default, a fifth of the space's extent, is
// metres in a building: nearly every long step ends in a wall) plus the largest yaw term of
// the distance, k pi. A step's state faces along the step's axis (ForwardSe2Space::interpolate),
// so its yaw term to the target stays up to k pi however near it comes: with a shorter range,
// RRT-Connect's connect loop (which checks no termination condition) would step for ever.
double tree_range(double turn_cost_m_per_rad) { return 1.0 + turn_cost_m_per_rad * kPi; }

ob::PlannerPtr make_planner(const std::string& name, const ob::SpaceInformationPtr& si, double range) {
  if (name == "rrtconnect") {
    auto p = std::make_shared<og::RRTConnect>(si);
    p->setRange(range);
    return p;
  }
  if (name == "rrtstar" || name == "informed_rrtstar") {
    auto p = name == "rrtstar" ? std::make_shared<og::RRTstar>(si) : std::make_shared<og::InformedRRTstar>(si);
    p->setRange(range);
    return p;
  }
  if (name == "prmstar") return std::make_shared<og::PRMstar>(si);
  if (name == "bitstar") {
    // OMPL 1.5's BIT* (Debian 12's) may prune the start and the goal of a direct start-goal
    // solution when there are several goal states, then dereferences them in
    // bestPathFromGoalToStart (a segfault; ompl/ompl#949, fixed in 1.6 by #1070): no pruning.
    auto bit = std::make_shared<og::BITstar>(si);
    bit->setPruning(false);
    return bit;
  }
  std::string names;
  for (const std::string& n : sampling_planners()) names += (names.empty() ? "" : ", ") + n;
  throw std::invalid_argument("plan_sampling: unknown planner '" + name + "' (one of " + names + ")");
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// How the follower reaches `to` from `from`: a turn in place to face it, a straight drive
// (forward, else backward where the robot may back), and, for the path's `last` pose, a turn to
// its yaw; an inner pose is reached at the heading held on the way (the next segment turns).
// The pose reached, or kBlocked when neither way is clear.
std::pair<Drive, Pose> reach(const TurnDriveModel& model, const Pose& from, const Pose& to, bool last) {
  if (last) return {model.clear_drive(from, to), to};
  Pose end = to;
  end[2] = TurnDriveModel::held(from, to, false);
  if (model.motion_clear(from, end, false)) return {Drive::kForward, end};
  if (model.reverse_factor() > 0) {
    end[2] = TurnDriveModel::held(from, to, true);
    if (model.motion_clear(from, end, true)) return {Drive::kBackward, end};
  }
  return {Drive::kBlocked, end};
}

// Appends `end`, reached from the path's last pose by `drive`, with its metres and turns.
void append(const TurnDriveModel& model, const Pose& end, Drive drive, SampledPath& out) {
  const Pose& from = out.poses.back();
  const bool backward = drive == Drive::kBackward;
  const auto [driven, turned] = TurnDriveModel::motion(from, end, backward);
  out.length_m += driven;
  out.turned_rad += turned;
  out.reversed_m += backward ? driven : 0.0;
  out.cost_m += model.cost(from, end, backward);
  out.poses.push_back(end);
  out.reversed.push_back(backward);
}

// The path as a follower drives it through `path`'s vertices: straight segments, forward where
// that is clear, else backward; each inner vertex's yaw the heading held on the segment into
// it, so that the turn there goes straight from one heading to the next. Fills `out`'s path
// and figures; false when such a turn (or anything else) is not clear.
bool follow(const TurnDriveModel& model, const og::PathGeometric& path, SampledPath& out) {
  std::vector<Pose> poses;
  for (std::size_t i = 0; i < path.getStateCount(); ++i) {
    const Pose p = pose_of(path.getState(i));
    if (!poses.empty() && norm(p[0] - poses.back()[0], p[1] - poses.back()[1]) < 1e-9 &&
        i + 1 < path.getStateCount())
      continue;  // a turn in place between two drives: the next drive's turn does it
    poses.push_back(p);
  }
  out.length_m = out.turned_rad = out.reversed_m = out.cost_m = 0.0;
  out.poses.assign(1, poses.front());
  out.reversed.assign(1, false);
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const auto [drive, end] = reach(model, out.poses.back(), poses[i], i + 1 == poses.size());
    if (drive == Drive::kBlocked) return false;
    append(model, end, drive, out);
  }
  return true;
}

}  // namespace

const std::vector<std::string>& sampling_planners() {
  static const std::vector<std::string> names{"rrtconnect", "rrtstar", "informed_rrtstar",
                                              "prmstar", "bitstar"};
  return names;
}

SampledPath plan_sampling(const std::int8_t* occupancy, int rows, int cols, double resolution_m,
                          const Footprint& footprint, const SamplingRequest& rq,
                          const std::vector<double>& goal_yaws) {
  const char* fn = "plan_sampling";
  validate(footprint, fn);
  if (rows <= 0 || cols <= 0) throw std::invalid_argument(std::string(fn) + ": empty grid");
  if (!(std::isfinite(resolution_m) && resolution_m > 0))
    throw std::invalid_argument(std::string(fn) + ": resolution must be > 0 m");
  if (!(std::isfinite(rq.budget_s) && rq.budget_s > 0))
    throw std::invalid_argument(std::string(fn) + ": budget_s must be > 0");
  if (!(std::isfinite(rq.margin_m) && rq.margin_m > 0))
    throw std::invalid_argument(std::string(fn) + ": margin_m must be > 0");
  if (!(std::isfinite(rq.reverse_cost_factor) && (rq.reverse_cost_factor == 0 || rq.reverse_cost_factor >= 1)))
    throw std::invalid_argument(std::string(fn) + ": reverse_cost_factor must be 0 (forward only) or >= 1");
  if (!(std::isfinite(rq.turn_margin_m) && rq.turn_margin_m >= 0))
    throw std::invalid_argument(std::string(fn) + ": turn_margin_m must be >= 0");
  if (!(std::isfinite(rq.turn_cost_m_per_rad) && rq.turn_cost_m_per_rad >= 0))
    throw std::invalid_argument(std::string(fn) + ": turn_cost_m_per_rad must be >= 0");
  for (double v : {rq.start[0], rq.start[1], rq.start[2], rq.goal[0], rq.goal[1]})
    if (!std::isfinite(v)) throw std::invalid_argument(std::string(fn) + ": start and goal must be finite");

  SampledPath out;
  TurnDriveModel model(occupancy, rows, cols, resolution_m, footprint, rq);
  if (!model.pose_clear(rq.start[0], rq.start[1], rq.start[2])) {
    out.reason = "the start is off the map, on an unknown or obstacle cell, or the footprint does not fit there";
    return out;
  }
  std::vector<double> yaws;
  for (double yaw : goal_yaws)
    if (std::isfinite(yaw) && model.pose_clear(rq.goal[0], rq.goal[1], yaw)) yaws.push_back(yaw);
  if (yaws.empty()) {
    out.reason = "the goal is off the map, on an unknown or obstacle cell, or the footprint fits there at none of the goal's headings";
    return out;
  }
  model.add_line_spots(rq.start[0], rq.start[1], rq.start[2], +1);
  if (model.reverse_factor() > 0) model.add_line_spots(rq.start[0], rq.start[1], rq.start[2], -1);
  // Goal states the robot can enter: where it turns at will, or along the line it arrives on
  // (forward, or backward where it may back); the longest way in first. RRT-Connect grows its
  // goal tree from the first goal state and takes the next only as that tree grows: a first
  // one that cannot be entered (a box facing across a corridor) would stop it for good.
  std::vector<std::pair<int, double>> entries;
  const bool turnable = model.turnable(rq.goal[0], rq.goal[1]);
  for (double yaw : yaws) {
    int way_in = model.add_line_spots(rq.goal[0], rq.goal[1], yaw, -1);
    if (model.reverse_factor() > 0) way_in += model.add_line_spots(rq.goal[0], rq.goal[1], yaw, +1);
    if (way_in > 0 || turnable) entries.push_back({way_in, yaw});
  }
  std::stable_sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  yaws.clear();
  for (const auto& e : entries) yaws.push_back(e.second);
  if (yaws.empty()) {
    out.reason = "the goal cannot be entered: the footprint fits there only at headings with no straight way in, and no turn in place";
    return out;
  }

  auto space = std::make_shared<ForwardSe2Space>();
  ob::RealVectorBounds bounds(2);
  bounds.setLow(0, 0.0), bounds.setHigh(0, cols * resolution_m);
  bounds.setLow(1, 0.0), bounds.setHigh(1, rows * resolution_m);
  space->setBounds(bounds);
  // The yaw's weight in the distance: a fifth of the metres a radian of turning costs (> 0 for
  // a metric). Any weight up to that cost keeps the heuristic a lower bound; a small one makes
  // the trees' neighbours the states near in position, which a motion's turns connect anyway
  // (with the full weight, RRT-Connect solved 1 of 3 maze pairs for the waffle_pi in 0.2 s,
  // with a fifth 2 of 3).
  space->setSubspaceWeight(1, std::max(0.2 * model.turn_cost(), 1e-3));
  space->setStateSamplerAllocator([&model](const ob::StateSpace* sp) -> ob::StateSamplerPtr {
    return std::make_shared<TurnSpotSampler>(sp, model);
  });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker([&model](const ob::State* s) {
    const Pose p = pose_of(s);
    return model.pose_clear(p[0], p[1], p[2]);
  });
  const Pose start_pose{rq.start[0], rq.start[1], so2(rq.start[2])};
  std::vector<Pose> goal_poses;
  for (double yaw : yaws) goal_poses.push_back({rq.goal[0], rq.goal[1], so2(yaw)});
  si->setMotionValidator(std::make_shared<TurnDriveValidator>(si, model, rq.planner == "prmstar",
                                                              start_pose, goal_poses));
  si->setup();

  ob::ScopedState<ob::SE2StateSpace> start(space);
  start->setXY(start_pose[0], start_pose[1]);
  start->setYaw(start_pose[2]);
  auto goal = std::make_shared<ob::GoalStates>(si);
  for (const Pose& p : goal_poses) {
    ob::ScopedState<ob::SE2StateSpace> g(space);
    g->setXY(p[0], p[1]);
    g->setYaw(p[2]);
    goal->addState(g);
  }
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  pdef->addStartState(start);
  pdef->setGoal(goal);
  auto objective = std::make_shared<TurnDriveObjective>(si, model);
  pdef->setOptimizationObjective(objective);

  ob::PlannerPtr planner = make_planner(rq.planner, si, tree_range(space->getSubspaceWeight(1)));
  planner->setProblemDefinition(pdef);
  planner->setup();
  auto t0 = std::chrono::steady_clock::now();
  const ob::PlannerStatus status = planner->solve(ob::timedPlannerTerminationCondition(rq.budget_s));
  out.solve_s = seconds_since(t0);
  {
    ob::PlannerData data(si);
    planner->getPlannerData(data);
    out.vertices = static_cast<int>(data.numVertices());
  }
  if (status != ob::PlannerStatus::EXACT_SOLUTION || !pdef->hasExactSolution()) {
    out.reason = std::string("no path within ") + std::to_string(rq.budget_s) + " s (" +
                 status.asString() + ")";
    return out;
  }
  const og::PathGeometric raw(*pdef->getSolutionPath()->as<og::PathGeometric>());
  og::PathGeometric path(raw);

  if (rq.simplify) {
    t0 = std::chrono::steady_clock::now();
    og::PathSimplifier simplifier(si, pdef->getGoal(), objective);
    const ob::PlannerTerminationCondition ptc = ob::timedPlannerTerminationCondition(rq.budget_s);
    for (bool better = true; better && !ptc;) {
      better = simplifier.reduceVertices(path);
      if (!ptc) better = simplifier.shortcutPath(path) || better;
      if (!ptc) better = simplifier.collapseCloseVertices(path) || better;
    }
    out.simplify_s = seconds_since(t0);
  }

  // The path the follower drives, from the simplified path or, where that one's turns at its
  // vertices straight from one heading to the next are not clear, the planner's own.
  if (!follow(model, path, out) && !(rq.simplify && follow(model, raw, out))) {
    out.reason = "the path's turns at its vertices, as the follower drives them, are not clear";
    return out;
  }
  out.solved = true;
  return out;
}

SampledPath shortcut_turn_drive(const std::int8_t* occupancy, int rows, int cols, double resolution_m,
                                const Footprint& footprint, const SamplingRequest& rq,
                                const std::vector<std::array<double, 2>>& points) {
  const char* fn = "shortcut_turn_drive";
  validate(footprint, fn);
  if (rows <= 0 || cols <= 0) throw std::invalid_argument(std::string(fn) + ": empty grid");
  if (!(std::isfinite(resolution_m) && resolution_m > 0))
    throw std::invalid_argument(std::string(fn) + ": resolution must be > 0 m");
  if (points.empty()) throw std::invalid_argument(std::string(fn) + ": the path has no points");
  for (const auto& p : points)
    if (!(std::isfinite(p[0]) && std::isfinite(p[1])))
      throw std::invalid_argument(std::string(fn) + ": the path's points must be finite");
  if (!std::isfinite(rq.start[2])) throw std::invalid_argument(std::string(fn) + ": the start yaw must be finite");

  SampledPath out;
  TurnDriveModel model(occupancy, rows, cols, resolution_m, footprint, rq);
  const Pose start{points[0][0], points[0][1], so2(rq.start[2])};
  if (!model.pose_clear(start[0], start[1], start[2])) {
    out.reason = "the start is off the map, on an unknown or obstacle cell, or the footprint does not fit there";
    return out;
  }
  out.poses.assign(1, start);
  out.reversed.assign(1, false);
  // From the last pose kept, the farthest later point reached by a turn in place and a
  // straight drive; the scan stops at the first point that is not, after one that is (a
  // line-of-sight shortcut's greedy rule, the sight being the swept footprint's). (A
  // depth-first search over these choices, farthest first, recovered 3 of the 70 waffle_pi
  // paths that this rule leaves unfollowable in bench-plan's pairs, at 4x the p95 time: those
  // paths pass where the box cannot turn to the next leg whatever the choice.)
  for (std::size_t i = 0; i + 1 < points.size();) {
    const Pose& from = out.poses.back();
    std::size_t best = 0;
    std::pair<Drive, Pose> way{Drive::kBlocked, Pose{}};
    for (std::size_t j = i + 1; j < points.size(); ++j) {
      if (norm(points[j][0] - from[0], points[j][1] - from[1]) < 1e-9) {
        if (!best) best = j;  // the same place: nothing to drive
        continue;
      }
      const auto r = reach(model, from, Pose{points[j][0], points[j][1], 0.0}, false);
      if (r.first != Drive::kBlocked) {
        best = j;
        way = r;
      } else if (best) {
        break;
      }
    }
    if (!best) {
      out.reason = "from (" + std::to_string(from[0]) + ", " + std::to_string(from[1]) +
                   ") m the footprint reaches no later point of the path by a turn in place and a straight drive";
      return out;
    }
    if (way.first != Drive::kBlocked) append(model, way.second, way.first, out);
    i = best;
  }
  out.solved = true;
  return out;
}

}  // namespace turtlebot_recon::planning

namespace {

namespace tp = turtlebot_recon::planning;
using namespace turtlebot_recon::bindings;

py::dict path_dict(const tp::SampledPath& path);

py::dict py_plan_sampling(const I8Grid& occupancy, double resolution, std::array<double, 3> start,
                          std::pair<double, double> goal_xy, std::vector<double> goal_yaws,
                          const std::string& planner, double budget_s,
                          double footprint_length_m, double footprint_width_m,
                          double footprint_offset_x_m, double radius_m, double margin_m,
                          double turn_margin_m, double turn_cost_m_per_rad,
                          double reverse_cost_factor, int occupied_threshold, bool simplify) {
  const Shape s = grid_shape(occupancy, "plan_sampling", "occupancy");
  tp::SamplingRequest rq;
  rq.planner = planner;
  rq.budget_s = budget_s;
  rq.margin_m = margin_m;
  rq.turn_margin_m = turn_margin_m;
  rq.reverse_cost_factor = reverse_cost_factor;
  rq.turn_cost_m_per_rad = turn_cost_m_per_rad;
  rq.occupied_threshold = occupied_threshold;
  rq.simplify = simplify;
  rq.start = start;
  rq.goal = {goal_xy.first, goal_xy.second};
  if (goal_yaws.empty()) fail("plan_sampling", "goal_yaws must name at least one heading");
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  tp::SampledPath path;
  {
    py::gil_scoped_release release;
    path = tp::plan_sampling(occupancy.data(), s.rows, s.cols, resolution, footprint, rq, goal_yaws);
  }
  return path_dict(path);
}

py::dict path_dict(const tp::SampledPath& path) {
  py::array_t<double> poses({static_cast<py::ssize_t>(path.poses.size()), py::ssize_t{3}});
  auto p = poses.mutable_unchecked<2>();
  for (size_t i = 0; i < path.poses.size(); ++i)
    for (int j = 0; j < 3; ++j) p(i, j) = path.poses[i][j];
  py::dict out;
  out["poses"] = poses;
  out["solved"] = path.solved;
  out["reason"] = path.reason;
  out["solve_s"] = path.solve_s;
  out["simplify_s"] = path.simplify_s;
  out["length_m"] = path.length_m;
  out["turned_rad"] = path.turned_rad;
  out["cost_m"] = path.cost_m;
  out["reversed_m"] = path.reversed_m;
  out["vertices"] = path.vertices;
  py::array_t<bool> reversed(static_cast<py::ssize_t>(path.reversed.size()));
  for (size_t i = 0; i < path.reversed.size(); ++i) reversed.mutable_data()[i] = path.reversed[i];
  out["reversed"] = reversed;
  return out;
}

py::dict py_shortcut_turn_drive(const I8Grid& occupancy, double resolution, const py::array_t<double>& points,
                                double start_yaw, double footprint_length_m, double footprint_width_m,
                                double footprint_offset_x_m, double radius_m, double margin_m,
                                double turn_margin_m, double turn_cost_m_per_rad, double reverse_cost_factor,
                                int occupied_threshold) {
  const Shape s = grid_shape(occupancy, "shortcut_turn_drive", "occupancy");
  if (points.ndim() != 2 || points.shape(1) != 2) fail("shortcut_turn_drive", "points must be an (n, 2) array");
  std::vector<std::array<double, 2>> pts(static_cast<size_t>(points.shape(0)));
  auto a = points.unchecked<2>();
  for (size_t i = 0; i < pts.size(); ++i) pts[i] = {a(i, 0), a(i, 1)};
  tp::SamplingRequest rq;
  rq.margin_m = margin_m;
  rq.turn_margin_m = turn_margin_m;
  rq.reverse_cost_factor = reverse_cost_factor;
  rq.turn_cost_m_per_rad = turn_cost_m_per_rad;
  rq.occupied_threshold = occupied_threshold;
  rq.start = {0.0, 0.0, start_yaw};
  const tp::Footprint footprint{footprint_length_m, footprint_width_m, footprint_offset_x_m, radius_m};
  tp::SampledPath path;
  {
    py::gil_scoped_release release;
    path = tp::shortcut_turn_drive(occupancy.data(), s.rows, s.cols, resolution, footprint, rq, pts);
  }
  return path_dict(path);
}

}  // namespace

void register_sampling(py::module_& m) {
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);  // OMPL's per-solve progress lines are noise here
  m.def("sampling_planners", &tp::sampling_planners, "The OMPL planners plan_sampling runs, by name.");
  m.def("plan_sampling", &py_plan_sampling, py::arg("occupancy"), py::arg("resolution"),
        py::arg("start"), py::arg("goal_xy"), py::arg("goal_yaws"), py::arg("planner"),
        py::arg("budget_s"), py::arg("footprint_length_m"), py::arg("footprint_width_m"),
        py::arg("footprint_offset_x_m"), py::arg("radius_m"), py::arg("margin_m"),
        py::arg("turn_margin_m"), py::arg("turn_cost_m_per_rad"), py::arg("reverse_cost_factor"), py::arg("occupied_threshold"), py::arg("simplify"),
        "An OMPL plan start -> goal for the footprint (include/turtlebot_recon/sampling_planner.hpp):\n"
        "start (x, y, yaw) and goal_xy in metres from the grid's corner, goal_yaws the headings the\n"
        "goal may be reached at (those where the footprint fits are goal states). A dict: poses\n"
        "(n, 3) start ... goal with each inner yaw the heading held on the segment into it,\n"
        "reversed (n,) whether that segment is driven backward, solved (an exact, followable\n"
        "path), reason (why not), solve_s, simplify_s, length_m, turned_rad, reversed_m, cost_m,\n"
        "vertices (the planner's graph or trees when it stopped).\n"
        "ValueError for an unknown planner or a bad argument.");
  m.def("shortcut_turn_drive", &py_shortcut_turn_drive, py::arg("occupancy"), py::arg("resolution"),
        py::arg("points"), py::arg("start_yaw"), py::arg("footprint_length_m"), py::arg("footprint_width_m"),
        py::arg("footprint_offset_x_m"), py::arg("radius_m"), py::arg("margin_m"), py::arg("turn_margin_m"),
        py::arg("turn_cost_m_per_rad"), py::arg("reverse_cost_factor"), py::arg("occupied_threshold"),
        "A 2-D path's points ((n, 2) m from the grid's corner, e.g. A*'s cells; the first the start,\n"
        "at start_yaw) shortened for the footprint as the follower drives it: from each kept pose\n"
        "the farthest later point reached by a turn in place and a straight drive (backward where\n"
        "the robot may back), the body clear all the way (include/turtlebot_recon/sampling_planner.hpp).\n"
        "plan_sampling's dict (solve_s, simplify_s and vertices 0); solved false, with the reason,\n"
        "where some kept pose reaches no later point.");
}
