// State-lattice A* over (row, col, heading) for a robot with an oriented footprint: state
// lattices (Pivtoraiko & Kelly 2005) with SBPL's 16 headings (Likhachev & Ferguson 2009), and
// hybrid A*'s 2-D heuristic (Dolgov et al. 2008). footprint.hpp says which cells a pose or a
// move of the body meets.
//
// States: a cell centre and one of K lattice headings (4, 8 or 16). Motion primitives:
//   forward  one lattice vector along the heading ((1,0), (2,1), (1,1), (1,2), ... for 16):
//            valid when the box swept along it, padded by margin_m, is clear of obstacle cells
//            and the cells the centre crosses are known;
//   backward one lattice vector back along the heading (when reverse_cost_factor > 0): the
//            same swept box as the forward move from where it ends;
//   turn     in place to the next heading either way: valid where the circumscribed disc
//            (radius + turn_margin_m) and every padded pose are clear (it could turn all the
//            way round there), or else where the box swept between the two headings, padded
//            by margin_m, is clear (a partial turn: a box squares up in a corridor too narrow
//            for its disc). A round robot's body is its disc, so it turns wherever it stands.
// Costs (metres):
//   forward  L * (1 + cost_weight * mean of the graded costs of the cells entered / 252), the
//            cost model of grid_search.hpp (one cell entered on a (1,0) or (1,1) move);
//   turn     |dtheta| * turn_cost_m_per_rad: seconds of turning at cruise speed;
//   backward reverse_cost_factor * the forward move's cost over the same cells (>= 1: the
//            2-D heuristic below stays a lower bound).
// Graded costs: the costmap convention (costmap.hpp) for the box: 254 obstacle, 255 unknown,
//   253 where no heading can fit (the nearest obstacle edge nearer than the box's inscribed
//   radius about base_footprint, plus the margin), below that 252 exp(-k (d - r_in)) out to
//   inflation_m, d measured to the obstacle's edge.
// Heuristic: the cost-to-go of the forward moves alone over the 2-D grid of cells where some
//   heading may fit (graded cost < 253), by a Dijkstra from the goal cell, run lazily: it
//   settles cells only until the one asked about is settled. Every lattice path projects onto
//   a path of that grid at no more cost (a backward move onto the opposite heading's forward
//   one), so the heuristic is admissible and consistent; a cell it never settles cannot reach
//   the goal, and its states are never opened. Plus the least turning (least_turn_rad).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/bresenham.hpp"
#include "turtlebot_recon/costmap.hpp"
#include "turtlebot_recon/distance_field.hpp"
#include "turtlebot_recon/footprint.hpp"
#include "turtlebot_recon/grid_search.hpp"

namespace turtlebot_recon::planning {

struct LatticeParams {
  double resolution_m = 0.05;
  int headings = 16;                 // K: 4, 8 or 16
  double margin_m = 0.02;            // clearance of the body to obstacle edges, > 0
  double turn_margin_m = 0.01;       // clearance of the turning disc (box robots), >= 0
  double cost_weight = 1.0;          // weight of the graded cost c / 252
  double inflation_m = 0.35;         // graded band beyond the inscribed radius
  double cost_scaling_factor = 5.0;  // 1/m, decay of the graded cost
  double turn_cost_m_per_rad = 0.325;  // cruise speed / turning speed (m/s per rad/s)
  int occupied_threshold = 65;       // occupancy (0..100) >= this is an obstacle
  bool unknown_is_obstacle = false;  // unknown cells (and off the grid) are obstacles too
  double reverse_cost_factor = 0.0;  // backward moves cost this x a forward one; 0: none
};

// Throws std::invalid_argument ("plan_lattice: ...") naming the first bad parameter.
inline void validate(const LatticeParams& p) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("plan_lattice: " + what); };
  auto finite_at_least = [](double v, double lo) { return std::isfinite(v) && v >= lo; };
  if (!(std::isfinite(p.resolution_m) && p.resolution_m > 0))
    fail("resolution must be a positive number of metres");
  if (p.headings != 4 && p.headings != 8 && p.headings != 16)
    fail("headings must be 4, 8 or 16, got " + std::to_string(p.headings));
  if (!(std::isfinite(p.margin_m) && p.margin_m > 0))
    fail("margin_m must be > 0 (a body touching an obstacle's edge collides), got " +
         std::to_string(p.margin_m));
  if (!finite_at_least(p.turn_margin_m, 0)) fail("turn_margin_m must be >= 0");
  if (!finite_at_least(p.cost_weight, 0)) fail("cost_weight must be >= 0 (the heuristic needs it)");
  if (!finite_at_least(p.inflation_m, 0)) fail("inflation_m must be >= 0");
  if (!finite_at_least(p.cost_scaling_factor, 0)) fail("cost_scaling_factor must be >= 0");
  if (!finite_at_least(p.turn_cost_m_per_rad, 0)) fail("turn_cost_m_per_rad must be >= 0");
  if (!(p.reverse_cost_factor == 0.0 || (std::isfinite(p.reverse_cost_factor) && p.reverse_cost_factor >= 1.0)))
    fail("reverse_cost_factor must be 0 (no backward moves) or >= 1");
  if (p.occupied_threshold < 1 || p.occupied_threshold > 100)
    fail("occupied_threshold must be in 1..100, got " + std::to_string(p.occupied_threshold));
}

struct LatticeState {
  int row, col, heading;
  bool turned;    // reached from the previous state by turning in place (false for the start)
  bool reversed;  // reached from the previous state by a backward move
};

struct LatticeSeed {  // a start state of cost_to_come and what reaching it costs
  Cell cell;
  int heading;
  double cost_m;
};

struct LatticePath {
  std::vector<LatticeState> states;  // start ... goal; empty when the goal is unreachable
  double cost = std::numeric_limits<double>::infinity();  // metres, as the search counts it
  double length_m = 0.0;             // driven
  double turned_rad = 0.0;           // turned in place
  double reversed_m = 0.0;           // of length_m, driven backward
  long long expanded = 0;            // states expanded
};

// One search over one occupancy grid (one object per call from Python). Like GridSearch it
// works on padded copies of the grid: a ring of `pad_` cells (unknown: obstacles only if
// unknown_is_obstacle) keeps every footprint offset and move in memory, so no loop checks
// bounds. Grid cell (r, c) is padded cell (r + pad_) * stride_ + c + pad_; state (cell, k) is
// cell * K + k.
class LatticeSearch {
 public:
  // occupancy: ROS int8 values (< 0 unknown, 0..100), row-major (rows, cols), row 0 = lowest y.
  LatticeSearch(const std::int8_t* occupancy, int rows, int cols, const Footprint& footprint,
                const LatticeParams& params)
      : rows_(rows), cols_(cols), p_(params), fp_(footprint) {
    validate(fp_, "plan_lattice");
    validate(p_);
    headings_ = lattice_headings(p_.headings);
    K_ = p_.headings;
    build_shapes();
    build_map(occupancy);
    for (int k = 0; k < K_; ++k) {
      const LatticeHeading& hd = headings_[k];
      step_[k] = hd.dr * stride_ + hd.dc;
      length_m_[k] = std::hypot(hd.dr, hd.dc) * p_.resolution_m;
      // the cells the centre enters on the move: its Bresenham line, less the start cell
      bresenham_line(0, 0, hd.dr, hd.dc, [&](int r, int c) {
        if (r != 0 || c != 0) entered_[k].push_back(r * stride_ + c);
        return true;
      });
      per_cost_unit_[k] = length_m_[k] * p_.cost_weight / (252.0 * entered_[k].size());
      ends_cover_move_[k] = !fp_.round() && length_m_[k] < fp_.length_m;
      for (int side = 0; side < 2; ++side) {  // 0: to k + 1 (left), 1: to k - 1 (right)
        const int to = side == 0 ? (k + 1) % K_ : (k + K_ - 1) % K_;
        turn_rad_[k][side] = std::fabs(std::remainder(headings_[to].yaw_rad - hd.yaw_rad, 2 * kPi));
      }
    }
  }

  const std::vector<LatticeHeading>& headings() const { return headings_; }

  // The graded costs of the header comment, row-major (rows, cols) into `out`, with 253 exact:
  // no heading's pose fits the cell (the search itself needs and uses only the cheaper bound,
  // the nearest obstacle inside the box's inscribed disc).
  void costmap(std::uint8_t* out) const {
    for (int r = 0; r < rows_; ++r) {
      std::uint8_t* row = out + static_cast<size_t>(r) * cols_;
      std::copy_n(&cost_[padded({r, 0})], cols_, row);
      for (int c = 0; c < cols_; ++c) {
        if (row[c] >= kInscribedObstacle) continue;
        const int i = padded({r, c});
        bool fits = false;
        for (int k = 0; k < K_ && !fits; ++k) fits = pose_[k].clear(obstacle_.data(), i, d2_[i]);
        if (!fits) row[c] = kInscribedObstacle;
      }
    }
  }

  // The cheapest lattice path from (start, start_heading) to the goal cell at goal_heading, or
  // at any heading when goal_heading < 0. Throws std::invalid_argument naming the endpoint when
  // either is off the grid, in an obstacle or unknown space, or when its footprint collides.
  LatticePath plan(Cell start, int start_heading, Cell goal, int goal_heading) {
    check_endpoint("start", start, start_heading);
    check_endpoint("goal", goal, goal_heading);
    goal_cell_ = padded(goal);
    goal_heading_ = goal_heading;
    start_dijkstra();
    LatticePath path;
    const int s0 = padded(start) * K_ + start_heading;
    if (!std::isfinite(cost_to_go_2d(padded(start)))) return path;  // different components
    if (!search(s0, &path.expanded)) return path;
    trace_back(&path);
    return path;
  }

  // Where the robot can get to: the cheapest lattice cost (m, as plan() counts it) from the
  // seed states to every cell at its cheapest heading, row-major (rows, cols) into `out`; +inf
  // where no state of the cell is reachable. A Dijkstra over the same moves as plan() (no
  // goal, no heuristic), so a cell is finite exactly when plan() finds a path to it at some
  // heading. Seeds off the grid or whose pose collides are skipped. Call once per object.
  //
  // turns_within_m: past this cost, a state whose cell lets the robot turn in place
  // (turn_clear) becomes the cell itself, at every heading (one node instead of K: it can turn
  // to any of them), and leaves it by any forward or backward move. Reach is unchanged (a
  // path through such nodes is a lattice path that turns in place there, and each lattice
  // path maps to one); costs up to turns_within_m are exact, beyond it they omit the turns
  // made in such cells (lower bounds). Where most of a map lets the robot turn, K times fewer
  // nodes.
  void cost_to_come(const std::vector<LatticeSeed>& seeds, float* out,
                    double turns_within_m = std::numeric_limits<double>::infinity()) {
    std::fill_n(out, static_cast<size_t>(rows_) * cols_, std::numeric_limits<float>::infinity());
    // Dial's buckets: every move costs at least its length (one cell or more; backward ones
    // reverse_cost_factor >= 1 times that), every turn turn_cost_m_per_rad x its angle.
    double cheapest = std::numeric_limits<double>::infinity(), dearest = 0.0;
    for (int k = 0; k < K_; ++k) {
      const double drive = length_m_[k] * (1.0 + p_.cost_weight) * std::max(1.0, p_.reverse_cost_factor);
      const double turn_lo = p_.turn_cost_m_per_rad * std::min(turn_rad_[k][0], turn_rad_[k][1]);
      const double turn_hi = p_.turn_cost_m_per_rad * std::max(turn_rad_[k][0], turn_rad_[k][1]);
      cheapest = std::min({cheapest, length_m_[k], turn_lo});
      dearest = std::max({dearest, drive, turn_hi});
    }
    double lowest_seed = std::numeric_limits<double>::infinity(), highest_seed = 0.0;
    for (const LatticeSeed& seed : seeds) {
      if (!(seed.cost_m >= 0)) continue;
      lowest_seed = std::min(lowest_seed, seed.cost_m);
      highest_seed = std::max(highest_seed, seed.cost_m);
    }
    // A turn that costs nothing (turn_cost_m_per_rad 0) gets buckets of a thousandth of a cell:
    // costs may then exceed the least by that much.
    const double width = std::max(cheapest * (1.0 - 1e-9), 1e-3 * p_.resolution_m);
    BucketQueue open(width, std::max(dearest, seeds.empty() ? 0.0 : highest_seed - lowest_seed) + width);
    // Queue ids: state s >= 0 (cell * K + k); a cell at every heading (past turns_within_m) is
    // -(cell + 1).
    std::vector<double> g_cell;
    std::vector<std::uint8_t> closed_cell;
    if (std::isfinite(turns_within_m)) {
      g_cell.assign(n_cells_, std::numeric_limits<double>::infinity());
      closed_cell.assign(n_cells_, 0);
    }
    auto open_state = [&](int s, double g) {
      const int cell = s / K_, k = s % K_;
      if ((closed_[cell] >> k) & 1) return;
      if (((reached_[cell] >> k) & 1) && g >= g_[s]) return;
      reached_[cell] |= 1u << k;
      g_[s] = g;
      open.push(g, s);
    };
    auto open_cell = [&](int cell, double g) {
      if (closed_cell[cell] || g >= g_cell[cell]) return;
      g_cell[cell] = g;
      open.push(g, -(cell + 1));
    };
    auto open_next = [&](int cell, int k, double g) {  // state (cell, k), or the cell past the bound
      if (g > turns_within_m && turn_clear(cell)) open_cell(cell, g);
      else open_state(cell * K_ + k, g);
    };
    auto record = [&](int cell, double g) {
      const Cell c = unpadded(cell);
      float& best = out[static_cast<size_t>(c.row) * cols_ + c.col];
      best = std::min(best, static_cast<float>(g));
    };
    for (const LatticeSeed& seed : seeds) {
      const Cell c = seed.cell;
      if (seed.heading < 0 || seed.heading >= K_ || !(seed.cost_m >= 0)) continue;
      if (!fits(c, seed.heading)) continue;
      open_next(padded(c), seed.heading, seed.cost_m);
    }
    while (!open.empty()) {
      const std::int32_t s = open.pop();
      if (s < 0) {  // a cell at every heading: forward and backward along each
        const int cell = -s - 1;
        if (closed_cell[cell]) continue;
        closed_cell[cell] = 1;
        const double g = g_cell[cell];
        record(cell, g);
        for (int k = 0; k < K_; ++k) {
          // Between two cells where the robot turns in place, a box moved along its own axis
          // by less than its length sweeps only its poses at the two ends, which fit there:
          // no sweep to check (a disc sweeps more than its two ends); backing there costs
          // more than driving forward the other way.
          const int ahead = cell + step_[k], behind = cell - step_[k];
          if ((ends_cover_move_[k] && turnable(ahead)) ? centre_passes(cell, k) : forward_clear(cell, k))
            open_next(ahead, k, g + forward_cost(cell, k));
          if (!turnable(behind) && backward_clear(cell, k)) open_next(behind, k, g + backward_cost(cell, k));
        }
        continue;
      }
      if (is_closed(s)) continue;
      const int cell = s / K_, k = s % K_;
      const double g = g_[s];   // <= turns_within_m where the robot turns in place (open_next)
      closed_[cell] |= 1u << k;
      record(cell, g);
      if (forward_clear(cell, k)) open_next(cell + step_[k], k, g + forward_cost(cell, k));
      if (backward_clear(cell, k)) open_next(cell - step_[k], k, g + backward_cost(cell, k));
      if (turn_ok(cell, k, 0)) open_next(cell, (k + 1) % K_, g + p_.turn_cost_m_per_rad * turn_rad_[k][0]);
      if (turn_ok(cell, k, 1))
        open_next(cell, (k + K_ - 1) % K_, g + p_.turn_cost_m_per_rad * turn_rad_[k][1]);
    }
  }

  // cost_to_come from a robot at cell `start` with yaw `yaw` (rad), starting as the navigator
  // does: where the turning disc fits at `start`, at every heading that fits there (each
  // costing the turn from `yaw`); else at the heading nearest `yaw` there, or the next nearest,
  // and its opposite (the robot backs out along its line); failing a forward one, at the first
  // cell straight ahead within snap_cells where one of those two headings fits (costing the
  // distance). When none of those fits (the robot brushes an obstacle), the nearest cells
  // within snap_cells where some heading fits, at each heading that does. `extra` seeds join
  // them (the escape arcs of planning/lattice.py). Returns false (all +inf) when there is none.
  bool reach_from(Cell start, double yaw, int snap_cells, const std::vector<LatticeSeed>& extra,
                  float* out, double turns_within_m = std::numeric_limits<double>::infinity()) {
    std::vector<LatticeSeed> seeds;
    yaw = std::remainder(yaw, 2 * kPi);
    std::vector<int> order(K_);  // headings by angle to yaw
    for (int k = 0; k < K_; ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return angle_between(headings_[a].yaw_rad, yaw) < angle_between(headings_[b].yaw_rad, yaw);
    });
    bool forward = false;
    if (fits(start, -1) && turn_clear(padded(start))) {
      for (int k = 0; k < K_; ++k)
        if (fits(start, k))
          seeds.push_back({start, k, p_.turn_cost_m_per_rad * angle_between(headings_[k].yaw_rad, yaw)});
      forward = true;
    } else {
      for (int n = 0; n < 2 && !forward; ++n) {
        const int k = order[n], back = (k + K_ / 2) % K_;
        if (fits(start, k)) {
          seeds.push_back({start, k, 0.0});
          forward = true;
        }
        if (fits(start, back)) seeds.push_back({start, back, 0.0});
      }
    }
    for (int d = 1; d <= snap_cells && !forward; ++d) {  // straight ahead while some heading fits
      const Cell c{start.row + static_cast<int>(std::lround(d * std::sin(yaw))),
                   start.col + static_cast<int>(std::lround(d * std::cos(yaw)))};
      if (!fits(c, -1)) break;
      for (int n = 0; n < 2 && !forward; ++n)
        if (fits(c, order[n])) {
          seeds.push_back({c, order[n], d * p_.resolution_m});
          forward = true;
        }
    }
    for (int d2 = 1; seeds.empty() && d2 <= snap_cells * snap_cells; ++d2) {
      for (int dr = -snap_cells; dr <= snap_cells; ++dr)
        for (int dc = -snap_cells; dc <= snap_cells; ++dc) {
          if (dr * dr + dc * dc != d2) continue;
          const Cell c{start.row + dr, start.col + dc};
          for (int k = 0; k < K_; ++k)
            if (fits(c, k)) seeds.push_back({c, k, std::sqrt(d2) * p_.resolution_m});
        }
    }
    seeds.insert(seeds.end(), extra.begin(), extra.end());
    cost_to_come(seeds, out, turns_within_m);
    return !seeds.empty();
  }

 private:
  enum Action : std::uint8_t { kStart, kForward, kTurnLeft, kTurnRight, kBackward };

  int padded(Cell c) const { return (c.row + pad_) * stride_ + c.col + pad_; }

  // Whether the footprint fits at `c`, at heading k (k < 0: at some heading).
  bool fits(Cell c, int k) const {
    if (c.row < 0 || c.row >= rows_ || c.col < 0 || c.col >= cols_) return false;
    const int i = padded(c);
    if (obstacle_[i] || !known_[i]) return false;
    if (k >= 0) return pose_[k].clear(obstacle_.data(), i, d2_[i]);
    for (int h = 0; h < K_; ++h)
      if (pose_[h].clear(obstacle_.data(), i, d2_[i])) return true;
    return false;
  }
  Cell unpadded(int i) const { return {i / stride_ - pad_, i % stride_ - pad_}; }

  // ---------------------------------------------------------------- set-up
  // The regions of footprint.hpp: the pose and the forward move at each heading, the turn.
  void build_shapes() {
    const double res = p_.resolution_m, m = p_.margin_m;
    const bool round = fp_.round();
    const double x0 = fp_.offset_x_m - 0.5 * fp_.length_m, x1 = fp_.offset_x_m + 0.5 * fp_.length_m;
    const double y0 = -0.5 * fp_.width_m, y1 = 0.5 * fp_.width_m;
    const double rho = round ? fp_.radius_m + m : m;  // a round body is a point padded
    const double corner = std::max(std::hypot(x0, y1), std::hypot(x1, y1));
    const double turn_radius = std::max(fp_.radius_m, corner) + (round ? m : p_.turn_margin_m);

    // The padding holds the farthest cell of any region (the turn, or the longest move's
    // farthest corner): bounded here, as the regions' offsets need the stride.
    const double longest_move = std::sqrt(5.0) * res;
    const double reach_m =
        std::max(turn_radius, std::max(std::hypot(x0, y1), std::hypot(x1 + longest_move, y1)) + rho);
    pad_ = static_cast<int>(std::ceil((reach_m + std::sqrt(0.5) * res) / res)) + 1;
    stride_ = cols_ + 2 * pad_;

    for (int k = 0; k < K_; ++k) {
      const LatticeHeading& hd = headings_[k];
      const double move = std::hypot(hd.dr, hd.dc) * res;
      pose_[k] = GridShape({{box_polygon(x0, x1, y0, y1), rho}}, hd.yaw_rad, res, stride_);
      move_[k] = GridShape({{box_polygon(x0, x1 + move, y0, y1), rho}}, hd.yaw_rad, res, stride_);
    }
    if (round) {
      turn_ = pose_[0];  // the disc itself: turning in place sweeps nothing new
    } else {
      std::vector<Region> spin{{{{0.0, 0.0}}, turn_radius}};
      for (const LatticeHeading& hd : headings_) {  // every padded pose, turned to yaw 0's frame
        const double c = std::cos(hd.yaw_rad), s = std::sin(hd.yaw_rad);
        std::vector<Vec2> box;
        for (Vec2 v : box_polygon(x0, x1, y0, y1)) box.push_back({c * v.x - s * v.y, s * v.x + c * v.y});
        spin.push_back({box, m});
      }
      turn_ = GridShape(spin, 0.0, res, stride_);
      // The box swept from heading k to each neighbour: its poses every <= kSweepStepRad,
      // padded by margin_m (the union misses only slivers r (1 - cos(step / 2)) < 0.3 mm deep
      // at the corners' arcs, r <= 0.3 m).
      for (int k = 0; k < K_; ++k) {
        for (int side = 0; side < 2; ++side) {
          const int to = side == 0 ? (k + 1) % K_ : (k + K_ - 1) % K_;
          const double delta = std::remainder(headings_[to].yaw_rad - headings_[k].yaw_rad, 2 * kPi);
          const int n = std::max(1, static_cast<int>(std::ceil(std::fabs(delta) / kSweepStepRad)));
          std::vector<Region> sweep;
          for (int i = 0; i <= n; ++i) {
            const double a = delta * i / n, c = std::cos(a), s = std::sin(a);
            std::vector<Vec2> box;
            for (Vec2 v : box_polygon(x0, x1, y0, y1)) box.push_back({c * v.x - s * v.y, s * v.x + c * v.y});
            sweep.push_back({box, m});
          }
          sweep_[k][side] = GridShape(sweep, headings_[k].yaw_rad, res, stride_);
        }
      }
    }
  }

  // Obstacle mask, distance field and graded costs on the padded grid.
  void build_map(const std::int8_t* occupancy) {
    const int prows = rows_ + 2 * pad_;
    n_cells_ = static_cast<size_t>(prows) * static_cast<size_t>(stride_);
    if (n_cells_ * K_ >= (size_t{1} << 31))
      throw std::invalid_argument("plan_lattice: grid too large (more than 2^31 states)");
    // 1. Obstacles; the padding is unknown space.
    obstacle_.assign(n_cells_, p_.unknown_is_obstacle ? 1 : 0);
    known_.assign(n_cells_, 0);
    for (int r = 0; r < rows_; ++r) {
      const std::int8_t* in = occupancy + static_cast<size_t>(r) * cols_;
      const size_t i0 = padded({r, 0});
      for (int c = 0; c < cols_; ++c) {
        known_[i0 + c] = in[c] >= 0;
        obstacle_[i0 + c] = in[c] >= p_.occupied_threshold || (in[c] < 0 && p_.unknown_is_obstacle);
      }
    }
    // 2. Squared distance (cells) from every cell centre to the nearest obstacle centre.
    d2_.resize(n_cells_);
    squared_distance_cells(obstacle_.data(), prows, stride_, d2_.data());
    // 3. Graded costs, cached by squared distance (integers) as inflate() does.
    const double h = 0.5 * p_.resolution_m, r_in = pose_[0].r_in_m();
    const double reject = pose_[0].reject_d2();
    const double band_m = r_in + h + p_.inflation_m;
    const int band_d2 = static_cast<int>(std::ceil(square(band_m / p_.resolution_m)));
    std::vector<std::uint8_t> graded(static_cast<size_t>(band_d2) + 1);
    for (int d2 = 0; d2 <= band_d2; ++d2) {
      // beyond: how far the obstacle's edge (half a cell nearer than its centre) lies past r_in
      const double beyond = std::sqrt(static_cast<double>(d2)) * p_.resolution_m - h - r_in;
      const double value = kMaxNonObstacle * std::exp(-p_.cost_scaling_factor * std::max(beyond, 0.0));
      graded[d2] = d2 < reject                      ? kInscribedObstacle
                   : beyond > p_.inflation_m + 1e-9 ? kFreeSpace
                   : static_cast<std::uint8_t>(std::clamp(std::floor(value), 0.0, 252.0));
    }
    cost_.resize(n_cells_);
    for (size_t i = 0; i < n_cells_; ++i) {
      cost_[i] = obstacle_[i]  ? kLethalObstacle
                 : !known_[i]  ? kNoInformation
                 : d2_[i] <= band_d2 ? graded[static_cast<int>(d2_[i])]
                                     : kFreeSpace;
    }
    // 4. Search buffers: g and the last action are read only where `reached_` says they were
    //    written, so they stay uninitialised (the pages of states never reached are never touched).
    g_.reset(new double[n_cells_ * K_]);
    action_.reset(new std::uint8_t[n_cells_ * K_]);
    reached_.assign(n_cells_, 0);
    closed_.assign(n_cells_, 0);
    turn_ok_.assign(n_cells_, kUnchecked);
    sweep_ok_.assign(fp_.round() ? 0 : n_cells_ * K_, 0);
    h_.assign(n_cells_, std::numeric_limits<double>::infinity());
    bearing_.assign(n_cells_, std::numeric_limits<double>::quiet_NaN());
    settled_.assign(n_cells_, 0);
  }

  static double square(double v) { return v * v; }

  // Throws std::invalid_argument naming the endpoint, e.g. "plan_lattice: goal (3, 4) is in an
  // obstacle"; heading < 0: some heading must fit.
  void check_endpoint(const char* what, Cell c, int heading) const {
    const std::string head = std::string("plan_lattice: ") + what + " " + to_string(c);
    if (c.row < 0 || c.row >= rows_ || c.col < 0 || c.col >= cols_)
      throw std::invalid_argument(head + " is outside the " + std::to_string(rows_) + " x " +
                                  std::to_string(cols_) + " grid");
    const int i = padded(c);
    if (obstacle_[i]) throw std::invalid_argument(head + " is in an obstacle");
    if (!known_[i]) throw std::invalid_argument(head + " is in unknown space");
    if (heading >= K_) throw std::invalid_argument(head + ": heading index out of range");
    const std::string body = fp_.round() ? "disc" : "box";
    if (heading >= 0 && !pose_[heading].clear(obstacle_.data(), i, d2_[i]))
      throw std::invalid_argument(head + " at heading " + degrees(heading) + ": the footprint's " +
                                  body + " comes within margin_m of an obstacle");
    if (heading < 0) {
      for (int k = 0; k < K_; ++k)
        if (pose_[k].clear(obstacle_.data(), i, d2_[i])) return;
      throw std::invalid_argument(head + ": no heading fits, the footprint's " + body +
                                  " comes within margin_m of an obstacle at every one");
    }
  }

  std::string degrees(int k) const {
    return std::to_string(static_cast<int>(std::lround(headings_[k].yaw_rad * 180.0 / kPi))) + " deg";
  }

  // ---------------------------------------------------------------- primitives
  // Forward from padded cell `a` along heading k: the entered cells known and free of
  // obstacles, the end cell where some heading may fit, the swept box clear.
  bool forward_clear(int a, int k) const {
    if (cost_[a + step_[k]] >= kInscribedObstacle) return false;
    for (std::int64_t e : entered_[k])
      if (cost_[a + e] >= kLethalObstacle) return false;
    return move_[k].clear(obstacle_.data(), a, d2_[a]);
  }

  // Padded cell `a` known, and the robot turns in place there (its poses at every heading fit).
  bool turnable(int a) { return cost_[a] < kInscribedObstacle && turn_clear(a); }

  // The centre's cells on the forward move from `a` along heading k all known and free.
  bool centre_passes(int a, int k) const {
    for (std::int64_t e : entered_[k])
      if (cost_[a + e] >= kLethalObstacle) return false;
    return true;
  }

  // Its cost: L (1 + cost_weight * mean graded cost of the entered cells / 252).
  double forward_cost(int a, int k) const {
    int sum = 0;
    for (std::int64_t e : entered_[k]) sum += std::min(cost_[a + e], kMaxNonObstacle);
    return length_m_[k] + per_cost_unit_[k] * sum;
  }

  // Backward from padded cell `a` along heading k: the forward move from where it ends.
  bool backward_clear(int a, int k) const {
    if (p_.reverse_cost_factor <= 0.0) return false;
    const int b = a - step_[k];
    return cost_[b] < kInscribedObstacle && forward_clear(b, k);
  }

  // Its cost: reverse_cost_factor x the forward move's the other way over the same cells.
  double backward_cost(int a, int k) const {
    return p_.reverse_cost_factor * forward_cost(a, (k + K_ / 2) % K_);
  }

  // Turning in place at padded cell `a` (memoised: every heading there asks).
  bool turn_clear(int a) {
    if (turn_ok_[a] == kUnchecked) turn_ok_[a] = turn_.clear(obstacle_.data(), a, d2_[a]) ? kYes : kNo;
    return turn_ok_[a] == kYes;
  }

  // Turning from heading k at padded cell `a` to k + 1 (side 0) or k - 1 (side 1): all the way
  // round is safe there, or the sweep to that neighbour is (memoised per state and side).
  bool turn_ok(int a, int k, int side) {
    if (turn_clear(a)) return true;
    if (fp_.round()) return false;
    std::uint8_t& memo = sweep_ok_[static_cast<size_t>(a) * K_ + k];
    const int shift = 2 * side;
    std::uint8_t known = (memo >> shift) & 3;
    if (known == kUnchecked) {
      known = sweep_[k][side].clear(obstacle_.data(), a, d2_[a]) ? kYes : kNo;
      memo |= known << shift;
    }
    return known == kYes;
  }

  // ---------------------------------------------------------------- heuristic
  void start_dijkstra() {
    h_[goal_cell_] = 0.0;
    dijkstra_open_.push(0.0, goal_cell_);
  }

  // Cost-to-go of forward moves from padded cell `a` to the goal, ignoring headings; +inf when
  // the goal is out of reach. Settles cells in order of cost until `a` is settled.
  double cost_to_go_2d(int a) {
    while (!settled_[a] && !dijkstra_open_.empty()) {
      const std::int32_t b = dijkstra_open_.pop();
      if (settled_[b]) continue;
      settled_[b] = 1;
      // Relax every move a' -> b that ends here: a' = b - step, both ends possibly valid.
      for (int k = 0; k < K_; ++k) {
        const int from = b - step_[k];
        if (settled_[from] || cost_[from] >= kInscribedObstacle) continue;
        bool passable = true;
        for (std::int64_t e : entered_[k]) passable = passable && cost_[from + e] < kLethalObstacle;
        if (!passable) continue;
        const double h_new = h_[b] + forward_cost(from, k);
        if (h_new < h_[from]) {
          h_[from] = h_new;
          dijkstra_open_.push(h_new, from);
        }
      }
    }
    return settled_[a] ? h_[a] : std::numeric_limits<double>::infinity();
  }

  // The least turning (rad) of any path from (padded cell a, heading k) to the goal. Its moves
  // add up to the vector D from a to the goal, so the headings it uses, an arc of them through
  // k (it turns in place from one to the next), must hold D's direction: it turns at least the
  // angle beta between k and D. Moving forward along k only widens beta, and a turn changes it
  // by no more than the turn, so adding the cost of beta keeps the heuristic consistent; so
  // does the angle to a required goal heading. With backward moves the arc's opposites move
  // too: the bound is the angle between D and k's line, min(beta, pi - beta); admissible, but
  // a move along the line can narrow it (the search may then miss the cheapest path by a
  // little, never a path).
  double least_turn_rad(int a, int k) {
    const double yaw = headings_[k].yaw_rad;
    if (std::isnan(bearing_[a])) {  // the direction of D, once per cell
      const int dr = goal_cell_ / stride_ - a / stride_, dc = goal_cell_ % stride_ - a % stride_;
      bearing_[a] = a == goal_cell_ ? std::numeric_limits<double>::infinity() : std::atan2(dr, dc);
    }
    double beta = std::isinf(bearing_[a]) ? 0.0 : angle_between(bearing_[a], yaw);
    if (p_.reverse_cost_factor > 0.0) beta = std::min(beta, kPi - beta);
    if (goal_heading_ >= 0) beta = std::max(beta, angle_between(headings_[goal_heading_].yaw_rad, yaw));
    return beta;
  }

  // |a - b| wrapped into [0, pi], for angles in [-pi, pi].
  static double angle_between(double a, double b) {
    const double d = std::fabs(a - b);
    return d > kPi ? 2 * kPi - d : d;
  }

  // h(a, k) = 2-D cost-to-go + turn_cost_m_per_rad * least turning.
  double heuristic(int a, int k) {
    return cost_to_go_2d(a) + p_.turn_cost_m_per_rad * least_turn_rad(a, k);
  }

  // ---------------------------------------------------------------- A*
  bool is_closed(std::int32_t s) const { return (closed_[s / K_] >> (s % K_)) & 1; }

  // Best-first search from state s0 until a goal state is closed.
  bool search(int s0, long long* expanded) {
    OpenList open([this](std::int32_t s) { return is_closed(s); });
    // h scaled by (1 + 1e-9): among equal f, the state nearer the goal first (as astar()).
    auto open_state = [&](int s, double g, Action how) {
      const int cell = s / K_, k = s % K_;
      if ((closed_[cell] >> k) & 1) return;
      if (((reached_[cell] >> k) & 1) && g >= g_[s]) return;
      const double h = heuristic(cell, k);
      if (!std::isfinite(h)) return;
      reached_[cell] |= 1u << k;
      g_[s] = g;
      action_[s] = how;
      open.push(g + (1.0 + 1e-9) * h, s);
    };
    open_state(s0, 0.0, kStart);
    while (!open.empty()) {
      // 1. Pop the open state with the lowest f = g + h; skip it if already closed (stale).
      const std::int32_t s = open.pop();
      if (is_closed(s)) continue;
      const int cell = s / K_, k = s % K_;
      closed_[cell] |= 1u << k;
      ++*expanded;
      // 2. Goal test: the goal cell, at the goal heading if one was asked for.
      if (cell == goal_cell_ && (goal_heading_ < 0 || k == goal_heading_)) {
        goal_state_ = s;
        return true;
      }
      // 3. Expand: forward along the heading, and turns in place where the disc fits.
      const double g = g_[s];
      if (forward_clear(cell, k))
        open_state((cell + step_[k]) * K_ + k, g + forward_cost(cell, k), kForward);
      if (backward_clear(cell, k))
        open_state((cell - step_[k]) * K_ + k, g + backward_cost(cell, k), kBackward);
      const double per_rad = p_.turn_cost_m_per_rad;
      if (turn_ok(cell, k, 0)) open_state(cell * K_ + (k + 1) % K_, g + per_rad * turn_rad_[k][0], kTurnLeft);
      if (turn_ok(cell, k, 1))
        open_state(cell * K_ + (k + K_ - 1) % K_, g + per_rad * turn_rad_[k][1], kTurnRight);
    }
    return false;
  }

  // Walk back from the goal state, undoing the action that reached each state.
  void trace_back(LatticePath* path) const {
    int s = goal_state_;
    path->cost = g_[s];
    for (;;) {
      const int cell = s / K_, k = s % K_;
      const Action how = static_cast<Action>(action_[s]);
      const Cell c = unpadded(cell);
      path->states.push_back({c.row, c.col, k, how == kTurnLeft || how == kTurnRight, how == kBackward});
      if (how == kStart) break;
      if (how == kForward) {
        path->length_m += length_m_[k];
        s = (cell - step_[k]) * K_ + k;
      } else if (how == kBackward) {
        path->length_m += length_m_[k];
        path->reversed_m += length_m_[k];
        s = (cell + step_[k]) * K_ + k;
      } else {
        const int from = how == kTurnLeft ? (k + K_ - 1) % K_ : (k + 1) % K_;
        path->turned_rad += turn_rad_[from][how == kTurnLeft ? 0 : 1];
        s = cell * K_ + from;
      }
    }
    std::reverse(path->states.begin(), path->states.end());
  }

  static constexpr std::uint8_t kUnchecked = 0, kYes = 1, kNo = 2;
  static constexpr double kSweepStepRad = 3.0 * kPi / 180.0;

  struct SettledTest {
    const std::vector<std::uint8_t>* settled;
    bool operator()(std::int32_t i) const { return (*settled)[i] != 0; }
  };

  int rows_, cols_;
  LatticeParams p_;
  Footprint fp_;
  std::vector<LatticeHeading> headings_;
  int K_ = 16, pad_ = 0, stride_ = 0;
  size_t n_cells_ = 0;
  // Per heading:
  std::array<GridShape, 16> pose_, move_;
  GridShape turn_;
  std::array<std::array<GridShape, 2>, 16> sweep_;      // box robots: the partial turns
  std::array<int, 16> step_{};                          // padded offset of the forward move
  std::array<double, 16> length_m_{};                   // its length
  std::array<std::vector<std::int64_t>, 16> entered_;   // the cells its centre enters
  std::array<double, 16> per_cost_unit_{};              // L cost_weight / (252 cells entered)
  std::array<bool, 16> ends_cover_move_{};              // the box's poses at both ends hold the move
  std::array<std::array<double, 2>, 16> turn_rad_{};    // to k + 1, to k - 1
  // Per padded cell:
  std::vector<std::uint8_t> obstacle_, known_, cost_;
  std::vector<float> d2_;                // squared distance (cells) to the nearest obstacle
  std::vector<std::uint16_t> reached_, closed_;  // a bit per heading
  std::vector<std::uint8_t> turn_ok_;    // kUnchecked, kYes, kNo
  std::vector<std::uint8_t> sweep_ok_;   // per state: 2 bits per side, kUnchecked, kYes, kNo
  std::vector<double> h_;                // heuristic (cost-to-go), final where settled_
  std::vector<std::uint8_t> settled_;
  std::vector<double> bearing_;          // direction (rad) to the goal; NaN: not yet, inf: the goal
  // Per state:
  std::unique_ptr<double[]> g_;
  std::unique_ptr<std::uint8_t[]> action_;
  // The search:
  OpenList<SettledTest> dijkstra_open_{SettledTest{&settled_}};
  int goal_cell_ = 0, goal_heading_ = -1, goal_state_ = -1;
};

}  // namespace turtlebot_recon::planning
