// Shortest paths on an 8-connected costmap: A* (Hart, Nilsson & Raphael 1968) and Dijkstra,
// with seed 001's visit-count penalty; and line-of-sight path shortcutting (seed 001's
// refinePath = seed 003's two-pointer shortcut).
//
// Cost model: entering cell b over a step of length L metres (resolution, or sqrt(2) x
// resolution on a diagonal) costs
//     L * (1 + cost_weight * c_b / 252 + visit_sensitivity * visits_b),
// c_b being b's costmap value. The factor is >= 1, so the octile distance in metres never
// overestimates the cost to go (admissible) and is consistent: a node's g is final when it
// is closed. astar() scales it by (1 + 1e-9) to break ties (see there).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/costmap.hpp"

namespace turtlebot_recon::planning {

struct CostModel {
  double resolution_m = 0.05;
  double visit_sensitivity = 0.5;  // extra cost per recorded visit of the entered cell
  double cost_weight = 1.0;        // weight of the costmap value c / 252
  int unknown_cost = -1;           // cost given to NO_INFORMATION cells; < 0: impassable
  int lethal_cost = 253;           // cells with cost >= lethal_cost are impassable
};

// Throws std::invalid_argument ("<fn>: ...") naming the first bad parameter.
inline void validate(const CostModel& m, const std::string& fn) {
  auto fail = [&fn](const std::string& what) { throw std::invalid_argument(fn + ": " + what); };
  if (!(std::isfinite(m.resolution_m) && m.resolution_m > 0))
    fail("resolution must be a positive number of metres");
  if (!(std::isfinite(m.visit_sensitivity) && m.visit_sensitivity >= 0))
    fail("visit_sensitivity must be >= 0 (a negative penalty breaks the A* heuristic)");
  if (!(std::isfinite(m.cost_weight) && m.cost_weight >= 0))
    fail("cost_weight must be >= 0 (a negative weight breaks the A* heuristic)");
  if (m.lethal_cost < 1 || m.lethal_cost > kLethalObstacle)
    fail("lethal_cost must be in 1..254, got " + std::to_string(m.lethal_cost));
  if (m.unknown_cost >= m.lethal_cost || m.unknown_cost > kMaxNonObstacle)
    fail("unknown_cost must be < 0 (forbid unknown cells) or in 0..min(252, lethal_cost - 1), "
         "got " + std::to_string(m.unknown_cost));
}

// The open list: a binary min-heap of (f, cell index) with lazy deletion (a cell pushed
// again with a lower f leaves its old entry in place; the caller skips it when popped).
// Keys and indices are stored apart so the sift loops walk a dense array of doubles, and
// pop() is Floyd's bottom-up deletion: move the hole down to a leaf along the smaller
// children, chosen without a branch (a coin flip a predictor loses half the time), then
// sift the last entry up from there.
class OpenList {
 public:
  explicit OpenList(size_t reserve) {
    f_.reserve(reserve);
    idx_.reserve(reserve);
  }
  bool empty() const { return f_.empty(); }

  void push(double f, std::int32_t idx) {
    f_.push_back(f);
    idx_.push_back(idx);
    sift_up(f_.size() - 1, f, idx);
  }

  // Removes the entry with the lowest f and returns its cell index.
  std::int32_t pop() {
    const std::int32_t top = idx_.front();
    const double last_f = f_.back();
    const std::int32_t last_idx = idx_.back();
    f_.pop_back();
    idx_.pop_back();
    const size_t n = f_.size();
    if (n == 0) return top;
    size_t hole = 0;
    for (size_t child = 1; child < n; child = 2 * hole + 1) {
      if (child + 1 < n) child += f_[child + 1] < f_[child];
      f_[hole] = f_[child];
      idx_[hole] = idx_[child];
      hole = child;
    }
    sift_up(hole, last_f, last_idx);
    return top;
  }

 private:
  void sift_up(size_t hole, double f, std::int32_t idx) {
    while (hole > 0) {
      const size_t parent = (hole - 1) / 2;
      if (!(f < f_[parent])) break;
      f_[hole] = f_[parent];
      idx_[hole] = idx_[parent];
      hole = parent;
    }
    f_[hole] = f;
    idx_[hole] = idx;
  }

  std::vector<double> f_;
  std::vector<std::int32_t> idx_;
};

struct GridPath {
  std::vector<Cell> cells;  // start ... goal; empty when the goal is unreachable
  double cost = std::numeric_limits<double>::infinity();
};

// One search over one costmap; g-scores, parents and closed flags are allocated once per
// search object (one object per call from Python).
class GridSearch {
 public:
  // cost: row-major (rows, cols) costmap; visits: same shape or nullptr (no penalty).
  GridSearch(const std::uint8_t* cost, const std::int32_t* visits, int rows, int cols,
             const CostModel& model, const std::string& fn)
      : cost_(cost), visits_(visits), rows_(rows), cols_(cols), model_(model), fn_(fn) {
    validate(model, fn);
    if (static_cast<long long>(rows) * cols >= (1LL << 31))
      throw std::invalid_argument(fn_ + ": grid too large (more than 2^31 cells)");
    const size_t n = size();
    if (visits_ != nullptr)
      for (size_t i = 0; i < n; ++i)
        if (visits_[i] < 0)
          throw std::invalid_argument(fn_ + ": visits must be >= 0, found " +
                                      std::to_string(visits_[i]) + " at " + to_string(cell(i)));
    // Factor of a step's length for entering a cell of each costmap value; -1 = impassable.
    for (int c = 0; c < 256; ++c) {
      int effective = c;
      if (c == kNoInformation) effective = model_.unknown_cost;  // < 0 forbids unknown cells
      else if (c >= model_.lethal_cost) effective = -1;
      weight_of_cost_[c] = effective < 0 ? -1.0 : 1.0 + model_.cost_weight * effective / 252.0;
    }
    const double diag = std::sqrt(2.0) * model_.resolution_m, straight = model_.resolution_m;
    // Moves 0-3 are orthogonal; diagonal k (4-7) is allowed only if both of its orthogonal
    // components, moves kOrthA[k - 4] and kOrthB[k - 4], are passable (no corner cutting).
    moves_ = {{{+1, 0, straight}, {-1, 0, straight}, {0, +1, straight}, {0, -1, straight},
               {+1, +1, diag}, {+1, -1, diag}, {-1, +1, diag}, {-1, -1, diag}}};
    for (int k = 0; k < 8; ++k) offset_[k] = moves_[k].dr * cols_ + moves_[k].dc;
    g_.assign(n, std::numeric_limits<double>::infinity());
    parent_.assign(n, -1);
    closed_.assign(n, 0);
  }

  // Throws std::invalid_argument if `c` (called `what`: "start" or "goal") is off the grid or
  // impassable, e.g. "astar: start (3, 4) is in lethal cost 254 (>= lethal_cost 253)".
  void check_endpoint(const char* what, Cell c) const {
    const std::string head = fn_ + ": " + what + " " + to_string(c);
    if (c.row < 0 || c.row >= rows_ || c.col < 0 || c.col >= cols_)
      throw std::invalid_argument(head + " is outside the " + std::to_string(rows_) + " x " +
                                  std::to_string(cols_) + " grid");
    const int v = cost_[index(c)];
    if (v == kNoInformation && model_.unknown_cost < 0)
      throw std::invalid_argument(head + " is in unknown space (cost 255) and unknown_cost < 0 "
                                         "forbids entering it");
    if (v != kNoInformation && v >= model_.lethal_cost) {
      const char* kind = v == kLethalObstacle      ? "lethal"
                         : v == kInscribedObstacle ? "inscribed"
                                                   : "high";
      throw std::invalid_argument(head + " is in " + kind + " cost " + std::to_string(v) +
                                  " (>= lethal_cost " + std::to_string(model_.lethal_cost) + ")");
    }
  }

  // A*: the cheapest 8-connected path start -> goal (both checked with check_endpoint).
  GridPath astar(Cell start, Cell goal) {
    check_endpoint("start", start);
    check_endpoint("goal", goal);
    // Octile distance in metres: the length of the shortest 8-connected move sequence,
    // scaled by (1 + 1e-9) so that among nodes of equal f (on open floor: every node between
    // start and goal, up to rounding) the one nearer the goal goes first. This tie-break
    // costs at most a relative 1e-9 of optimality and saves most expansions on open floors.
    const double straight = (1.0 + 1e-9) * model_.resolution_m;
    const double diag_extra = (std::sqrt(2.0) - 1.0) * straight;
    auto octile = [&](int r, int c) {
      const int dr = std::abs(r - goal.row), dc = std::abs(c - goal.col);
      return straight * std::max(dr, dc) + diag_extra * std::min(dr, dc);
    };
    GridPath path;
    const int goal_idx = index(goal);
    if (!search(index(start), goal_idx, octile)) return path;
    // Walk the parents back from the goal.
    for (int i = goal_idx; i != -1; i = parent_[i]) path.cells.push_back(cell(i));
    std::reverse(path.cells.begin(), path.cells.end());
    path.cost = g_[goal_idx];
    return path;
  }

  // Dijkstra: cost-to-come from start to every cell (+inf where unreachable or impassable).
  void dijkstra(Cell start, float* cost_to_come) {
    check_endpoint("start", start);
    search(index(start), -1, [](int, int) { return 0.0; });
    for (size_t i = 0; i < size(); ++i) cost_to_come[i] = static_cast<float>(g_[i]);
  }

 private:
  struct Move {
    int dr, dc;
    double length_m;
  };
  static constexpr std::array<int, 4> kOrthA = {0, 0, 1, 1};  // row part of diagonals 4..7
  static constexpr std::array<int, 4> kOrthB = {2, 3, 2, 3};  // column part

  size_t size() const { return static_cast<size_t>(rows_) * static_cast<size_t>(cols_); }
  int index(Cell c) const { return c.row * cols_ + c.col; }
  Cell cell(size_t i) const { return {static_cast<int>(i / cols_), static_cast<int>(i % cols_)}; }

  // Factor 1 + cost_weight c/252 + visit_sensitivity visits of entering cell idx; < 0 if
  // it cannot be entered.
  double entry_weight(int idx) const {
    const double w = weight_of_cost_[cost_[idx]];
    if (w < 0 || visits_ == nullptr) return w;
    return w + model_.visit_sensitivity * visits_[idx];
  }

  // Best-first search from start (lazy-deletion binary heap). Stops when goal (>= 0) is
  // closed; with goal = -1 and h = 0 it is Dijkstra over the whole grid. Returns whether
  // the goal was reached.
  template <class Heuristic>
  bool search(int start, int goal, Heuristic h) {
    OpenList open(std::min<size_t>(size(), 1u << 16));
    g_[start] = 0.0;
    open.push(h(start / cols_, start % cols_), start);
    std::array<double, 8> w;  // entry factor of each neighbour, < 0 if not enterable
    while (!open.empty()) {
      // 1. Pop the open node n with the lowest f = g + h.
      const std::int32_t n = open.pop();
      // 2. Lazy deletion: skip a stale entry, left behind when n was pushed again with a
      //    lower g and has been closed since.
      if (closed_[n]) continue;
      closed_[n] = 1;
      // 3. Goal test: g(goal) is optimal once the goal is closed.
      if (n == goal) return true;
      // 4. Expand n: relax every neighbour b, g(b) = min(g(b), g(n) + L * factor(b)).
      const int r = n / cols_, c = n % cols_;
      const double g_n = g_[n];
      const bool interior = r > 0 && r < rows_ - 1 && c > 0 && c < cols_ - 1;
      for (int k = 0; k < 8; ++k) {
        const int rb = r + moves_[k].dr, cb = c + moves_[k].dc;
        const bool inside = interior || (rb >= 0 && rb < rows_ && cb >= 0 && cb < cols_);
        w[k] = inside ? entry_weight(n + offset_[k]) : -1.0;
      }
      for (int k = 0; k < 8; ++k) {
        if (w[k] < 0) continue;
        if (k >= 4 && (w[kOrthA[k - 4]] < 0 || w[kOrthB[k - 4]] < 0)) continue;  // corner
        const int b = n + offset_[k];
        if (closed_[b]) continue;
        const double g_new = g_n + moves_[k].length_m * w[k];
        if (g_new < g_[b]) {
          g_[b] = g_new;
          parent_[b] = n;
          open.push(g_new + h(r + moves_[k].dr, c + moves_[k].dc), b);
        }
      }
    }
    return false;
  }

  const std::uint8_t* cost_;
  const std::int32_t* visits_;
  int rows_, cols_;
  CostModel model_;
  std::string fn_;
  std::array<double, 256> weight_of_cost_{};
  std::array<Move, 8> moves_{};
  std::array<int, 8> offset_{};  // index offset of each move
  std::vector<double> g_;
  std::vector<std::int32_t> parent_;
  std::vector<std::uint8_t> closed_;
};

// Calls visit(cell) for each cell of the Bresenham line a -> b (both ends included, in
// order) until visit returns false; returns whether every call returned true.
template <class Visit>
bool bresenham_line(Cell a, Cell b, Visit visit) {
  const int dr = std::abs(b.row - a.row), sr = a.row < b.row ? 1 : -1;
  const int dc = -std::abs(b.col - a.col), sc = a.col < b.col ? 1 : -1;
  int err = dr + dc, r = a.row, c = a.col;
  while (true) {
    if (!visit(Cell{r, c})) return false;
    if (r == b.row && c == b.col) return true;
    const int e2 = 2 * err;
    if (e2 >= dc) {  // step in rows
      err += dc;
      r += sr;
    }
    if (e2 <= dr) {  // step in columns
      err += dr;
      c += sc;
    }
  }
}

// Line-of-sight shortcut of a grid path (seed 001's refinePath, seed 003's two-pointer
// shortcut). From waypoint i, keep the farthest later index j whose Bresenham line i -> j
// stays on cells with cost < lethal_cost and <= the highest cost of the path cells i..j (so
// a shortcut never runs closer to obstacles than the path already did); continue from j.
// Unknown cells (255) never lie on a shortcut. Paths of 0-2 cells come back unchanged.
// Throws std::invalid_argument if a path cell is off the grid.
inline std::vector<Cell> shortcut_path(const std::vector<Cell>& path, const std::uint8_t* cost,
                                       int rows, int cols, int lethal_cost) {
  const int n = static_cast<int>(path.size());
  for (int i = 0; i < n; ++i)
    if (path[i].row < 0 || path[i].row >= rows || path[i].col < 0 || path[i].col >= cols)
      throw std::invalid_argument("shortcut: path point " + std::to_string(i) + " " +
                                  to_string(path[i]) + " is outside the grid");
  if (lethal_cost < 1 || lethal_cost > 255)
    throw std::invalid_argument("shortcut: lethal_cost must be in 1..255");
  if (n <= 2) return path;
  auto cost_at = [&](Cell c) {
    return static_cast<int>(cost[static_cast<size_t>(c.row) * cols + c.col]);
  };

  std::vector<Cell> out{path[0]};
  std::vector<int> ceiling(n);  // ceiling[j]: highest cost a line i -> j may cross
  int i = 0;
  while (i < n - 1) {
    // 1. Highest cost of the original path cells i..j, for every j > i.
    int highest = cost_at(path[i]);
    for (int j = i + 1; j < n; ++j) {
      highest = std::max(highest, cost_at(path[j]));
      ceiling[j] = std::min(highest, lethal_cost - 1);
    }
    // 2. Farthest j first: the first line that stays under its ceiling wins; the next
    //    path cell (j = i + 1) is always reachable.
    int j = n - 1;
    for (; j > i + 1; --j) {
      const int limit = ceiling[j];
      if (bresenham_line(path[i], path[j], [&](Cell c) { return cost_at(c) <= limit; })) break;
    }
    // 3. Keep j and continue from it.
    out.push_back(path[j]);
    i = j;
  }
  return out;
}

}  // namespace turtlebot_recon::planning
