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
//   heading may fit (graded cost < 253), by a search from the goal cell toward the start, run
//   lazily: it settles cells only until the one asked about is settled (cost_to_go_2d). Every
//   lattice path projects onto a path of that grid at no more cost (a backward move onto the
//   opposite heading's forward one), so the heuristic is admissible and consistent; a cell it
//   never settles cannot reach the goal, and its states are never opened. Plus the least
//   turning (least_turn_rad).
// What depends on neither start nor goal (the footprint's regions, the map's distance field and
// graded costs) is built apart and shared between searches: lattice_grid.hpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/bresenham.hpp"
#include "turtlebot_recon/costmap.hpp"
#include "turtlebot_recon/distance_field.hpp"
#include "turtlebot_recon/footprint.hpp"
#include "turtlebot_recon/grid_search.hpp"
#include "turtlebot_recon/lattice_grid.hpp"

namespace turtlebot_recon::planning {

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

// One search over one occupancy grid (one object per call from Python), on the padded grid of
// its LatticeMap (lattice_grid.hpp): a ring of `pad_` cells (unknown: obstacles only if
// unknown_is_obstacle) keeps every footprint offset and move in memory, so no loop checks
// bounds. Grid cell (r, c) is padded cell (r + pad_) * stride_ + c + pad_; state (cell, k) is
// cell * K + k.
class LatticeSearch {
 public:
  // Over the shapes and map of lattice_grid.hpp (shared with other searches, read only).
  LatticeSearch(std::shared_ptr<const LatticeShapes> shapes, std::shared_ptr<const LatticeMap> map)
      : shapes_(std::move(shapes)), map_(std::move(map)), rows_(map_->rows), cols_(map_->cols),
        p_(shapes_->p), fp_(shapes_->fp), headings_(shapes_->headings), K_(shapes_->K),
        pad_(shapes_->pad), stride_(shapes_->stride), n_cells_(map_->n_cells),
        pose_(shapes_->pose), move_(shapes_->move), turn_(shapes_->turn), sweep_(shapes_->sweep),
        step_(shapes_->step), length_m_(shapes_->length_m), entered_(shapes_->entered),
        per_cost_unit_(shapes_->per_cost_unit), ends_cover_move_(shapes_->ends_cover_move),
        turn_rad_(shapes_->turn_rad), obstacle_(map_->obstacle), known_(map_->known),
        cost_(map_->cost), d2_(map_->d2) {
    if (map_->shapes != shapes_) throw std::logic_error("LatticeSearch: a map built for other shapes");
    allocate_search();
  }

  // occupancy: ROS int8 values (< 0 unknown, 0..100), row-major (rows, cols), row 0 = lowest y.
  LatticeSearch(const std::int8_t* occupancy, int rows, int cols, const Footprint& footprint,
                const LatticeParams& params)
      : LatticeSearch(std::make_shared<const LatticeShapes>(footprint, params, cols), occupancy, rows, cols) {}

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
    start_reverse_search(padded(start));
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
      const int cell = cell_of(s), k = heading_of(s);
      if ((cells_[cell].closed >> k) & 1) return;
      if (((cells_[cell].reached >> k) & 1) && g >= g_[s]) return;
      cells_[cell].reached |= 1u << k;
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
      const int cell = cell_of(s), k = heading_of(s);
      const double g = g_[s];   // <= turns_within_m where the robot turns in place (open_next)
      cells_[cell].closed |= 1u << k;
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
  struct Free {
    void operator()(void* p) const { std::free(p); }
  };
  template <class T>
  using Zeroed = std::unique_ptr<T[], Free>;  // from zeroed()

  LatticeSearch(std::shared_ptr<const LatticeShapes> shapes, const std::int8_t* occupancy, int rows, int cols)
      : LatticeSearch(shapes, std::make_shared<const LatticeMap>(occupancy, rows, cols, shapes)) {}

  // Search buffers, sized by the grid but paid for by the cells the search touches: g and the
  // last action are read only where `reached` says they were written, so they stay
  // uninitialised; the per-cell records (h and the bearing read only where their flags say
  // written) and the sweep memos start at zero (calloc: a fresh large block is the kernel's
  // zero pages, untouched where no cell is reached; one recycled from the heap is cleared).
  void allocate_search() {
    k_bits_ = 0;
    while ((1 << k_bits_) < K_) ++k_bits_;
    g_.reset(new double[n_cells_ * K_]);
    action_.reset(new std::uint8_t[n_cells_ * K_]);
    cells_ = zeroed<CellState>(n_cells_);  // turn_ok kUnchecked
    sweep_ok_ = zeroed<std::uint8_t>(fp_.round() ? 1 : n_cells_ * K_);
  }

  // n zeroed T (trivial types), the pages untouched until written.
  template <class T>
  static Zeroed<T> zeroed(size_t n) {
    void* p = std::calloc(n, sizeof(T));
    if (p == nullptr) throw std::bad_alloc();
    return Zeroed<T>(static_cast<T*>(p));
  }

  int cell_of(std::int32_t s) const { return s >> k_bits_; }
  int heading_of(std::int32_t s) const { return s & (K_ - 1); }
  bool settled(int a) const { return cells_[a].flags & kSettled; }

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
    if (cells_[a].turn_ok == kUnchecked) cells_[a].turn_ok = turn_.clear(obstacle_.data(), a, d2_[a]) ? kYes : kNo;
    return cells_[a].turn_ok == kYes;
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
  // The 2-D cost-to-go comes from a search backward from the goal toward the start, resumed
  // whenever a cell not yet settled is asked about (Reverse Resumable A*, Silver 2005): it
  // pops cells in order of h + the shortest lattice drive to the start (a lower bound on
  // every move's cost, so consistent: each cell it settles holds its exact cost-to-go, the
  // value a Dijkstra from the goal gives). The lattice search asks only about cells whose h + g
  // stays below the plan's cost, and g is at least the straight distance from the start:
  // the cells settled lie in the ellipse of foci start and goal, not the disc round the goal.
  void start_reverse_search(int start_cell) {
    start_row_ = start_cell / stride_;
    start_col_ = start_cell % stride_;
    cells_[goal_cell_].h = 0.0;
    cells_[goal_cell_].flags |= kHasH;
    reverse_open_.push(to_start_m(goal_cell_ / stride_, goal_cell_ % stride_), goal_cell_);
  }

  // The shortest drive (m) from padded cell (row, col) to the start cell along lattice
  // vectors alone: by symmetry in the octant x >= y >= 0, the two vectors either side of
  // (x, y) (16 headings: (1, 0), (2, 1), (1, 1); 8: (1, 0), (1, 1); 4: (1, 0) and (0, 1)).
  // A norm no longer than any move's cost, so a consistent key; 1-3 % above the straight
  // distance between the headings, which narrows the ellipse.
  double to_start_m(int row, int col) const {
    double x = std::abs(col - start_col_), y = std::abs(row - start_row_);
    if (y > x) std::swap(x, y);
    double cells;
    if (K_ == 4) cells = x + y;
    else if (K_ == 8) cells = kSqrt2 * y + (x - y);
    else if (2 * y <= x) cells = kSqrt5 * y + (x - 2 * y);        // (2, 1) and (1, 0)
    else cells = kSqrt2 * (2 * y - x) + kSqrt5 * (x - y);         // (1, 1) and (2, 1)
    return p_.resolution_m * cells;
  }

  // Cost-to-go of forward moves from padded cell `a` to the goal, ignoring headings; +inf when
  // the goal is out of reach. Settles cells until `a` is settled.
  double cost_to_go_2d(int a) {
    while (!settled(a) && !reverse_open_.empty()) {
      const std::int32_t b = reverse_open_.pop();
      if (settled(b)) continue;
      cells_[b].flags |= kSettled;
      const int row = b / stride_, col = b % stride_;
      // Relax every move a' -> b that ends here: a' = b - step, both ends possibly valid.
      for (int k = 0; k < K_; ++k) {
        const int from = b - step_[k];
        if (settled(from) || cost_[from] >= kInscribedObstacle) continue;
        bool passable = true;
        for (std::int64_t e : entered_[k]) passable = passable && cost_[from + e] < kLethalObstacle;
        if (!passable) continue;
        const double h_new = cells_[b].h + forward_cost(from, k);
        if (!(cells_[from].flags & kHasH) || h_new < cells_[from].h) {
          cells_[from].h = h_new;
          cells_[from].flags |= kHasH;
          const LatticeHeading& hd = headings_[k];
          reverse_open_.push(h_new + to_start_m(row - hd.dr, col - hd.dc), from);
        }
      }
    }
    return settled(a) ? cells_[a].h : std::numeric_limits<double>::infinity();
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
    if (!(cells_[a].flags & kHasBearing)) {  // the direction of D, once per cell
      cells_[a].flags |= kHasBearing;
      const int dr = goal_cell_ / stride_ - a / stride_, dc = goal_cell_ % stride_ - a % stride_;
      cells_[a].bearing = a == goal_cell_ ? std::numeric_limits<double>::infinity() : std::atan2(dr, dc);
    }
    double beta = std::isinf(cells_[a].bearing) ? 0.0 : angle_between(cells_[a].bearing, yaw);
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
  bool is_closed(std::int32_t s) const { return (cells_[cell_of(s)].closed >> heading_of(s)) & 1; }

  // Best-first search from state s0 until a goal state is closed.
  bool search(int s0, long long* expanded) {
    OpenList open([this](std::int32_t s) { return is_closed(s); });
    // h scaled by (1 + 1e-9): among equal f, the state nearer the goal first (as astar()).
    // Inlined by force: four calls per expansion, and left out of line it costs ~30 % on a
    // 2,000 x 2,000 grid.
    auto open_state = [&](int s, double g, Action how) __attribute__((always_inline)) {
      const int cell = cell_of(s), k = heading_of(s);
      if ((cells_[cell].closed >> k) & 1) return;
      if (((cells_[cell].reached >> k) & 1) && g >= g_[s]) return;
      const double h = heuristic(cell, k);
      if (!std::isfinite(h)) return;
      cells_[cell].reached |= 1u << k;
      g_[s] = g;
      action_[s] = how;
      open.push(g + (1.0 + 1e-9) * h, s);
    };
    open_state(s0, 0.0, kStart);
    while (!open.empty()) {
      // 1. Pop the open state with the lowest f = g + h; skip it if already closed (stale).
      const std::int32_t s = open.pop();
      if (is_closed(s)) continue;
      const int cell = cell_of(s), k = heading_of(s);
      cells_[cell].closed |= 1u << k;
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
      const int cell = cell_of(s), k = heading_of(s);
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
  static constexpr double kSqrt2 = 1.41421356237309504880, kSqrt5 = 2.23606797749978969641;

  // Per-cell flags of the heuristic.
  static constexpr std::uint8_t kSettled = 1, kHasH = 2, kHasBearing = 4;

  // What the search keeps per padded cell, in one place (one cache line where it had six).
  struct CellState {
    double h;                  // heuristic (cost-to-go), where kHasH; final where kSettled
    double bearing;            // direction (rad) to the goal, where kHasBearing; inf: the goal
    std::uint16_t reached;     // a bit per heading
    std::uint16_t closed;      // a bit per heading
    std::uint8_t flags;        // kSettled, kHasH, kHasBearing
    std::uint8_t turn_ok;      // kUnchecked, kYes, kNo
  };

  struct SettledTest {
    const Zeroed<CellState>* cells;
    bool operator()(std::int32_t i) const { return ((*cells)[i].flags & kSettled) != 0; }
  };

  // What the search reads (lattice_grid.hpp), shared; the hot loops use the references below.
  std::shared_ptr<const LatticeShapes> shapes_;
  std::shared_ptr<const LatticeMap> map_;
  int rows_, cols_;
  const LatticeParams& p_;
  const Footprint& fp_;
  const std::vector<LatticeHeading>& headings_;
  int K_, pad_, stride_;
  int k_bits_ = 0;                       // K = 2^k_bits_
  size_t n_cells_;
  // Per heading:
  const std::array<GridShape, 16>& pose_;
  const std::array<GridShape, 16>& move_;
  const GridShape& turn_;
  const std::array<std::array<GridShape, 2>, 16>& sweep_;   // box robots: the partial turns
  const std::array<int, 16> step_;                          // padded offset of the forward move
  const std::array<double, 16> length_m_;                   // its length
  const std::array<std::vector<std::int64_t>, 16>& entered_;  // the cells its centre enters
  const std::array<double, 16> per_cost_unit_;              // L cost_weight / (252 cells entered)
  const std::array<bool, 16> ends_cover_move_;              // the box's poses at both ends hold the move
  const std::array<std::array<double, 2>, 16> turn_rad_;    // to k + 1, to k - 1
  // Per padded cell, the map's:
  const std::vector<std::uint8_t>& obstacle_;
  const std::vector<std::uint8_t>& known_;
  const std::vector<std::uint8_t>& cost_;
  const std::vector<float>& d2_;         // squared distance (cells) to the nearest obstacle
  // Per padded cell, this search's:
  Zeroed<CellState> cells_;
  Zeroed<std::uint8_t> sweep_ok_;        // per state: 2 bits per side, kUnchecked, kYes, kNo
  // Per state:
  std::unique_ptr<double[]> g_;
  std::unique_ptr<std::uint8_t[]> action_;
  // The search:
  OpenList<SettledTest> reverse_open_{SettledTest{&cells_}};
  int start_row_ = 0, start_col_ = 0;    // padded, of the start cell (the reverse search's target)
  int goal_cell_ = 0, goal_heading_ = -1, goal_state_ = -1;
};

}  // namespace turtlebot_recon::planning
