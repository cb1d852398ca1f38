// Seed 003's RRT (its section 3.3, "Path Planning via RRT"), reproduced as a baseline planner:
//
//   repeat at most max_steps times (SMAX), while the tree has fewer than max_nodes (NMAX):
//     1. sample a target: the goal with probability goal_fraction (RRT_GOAL_SELECT_FRACTION),
//        else a uniformly drawn cell's centre;
//     2. nearest: the tree node nearest the target (Euclidean, a linear scan);
//     3. step: new = nearest + step_cells (RRT_STEP_SCALE) x the unit vector to the target;
//     4. keep new when its hit-box is free at new and along nearest -> new;
//     5. when new lies within one step of the goal and the hit-box is free along new -> goal,
//        add the goal and stop: the path is the goal's parent chain;
//   then the two-pointer shortcut (seed 003's post-processing, "1-6 segments").
//
// The hit-box (BOT_WIDTH_CLEARANCE x BOT_LENGTH_CLEARANCE cells) is an axis-aligned box
// centred on the robot's position that never turns with it, as in the seed; it is free where
// it overlaps no obstacle cell's square (touching is allowed) and no cell off the grid. Along a
// connection the box sweeps the segment; free_along() tests that sweep exactly (the cells the
// box overlaps change only where one of its edges crosses a grid line, so the box is tested
// once between each two such crossings), with a summed-area table: O(1) per box.
//
// Coordinates are in cells: cell (row, col) is the square [col, col + 1) x [row, row + 1),
// x = col, y = row (row 0 = smallest y, as the occupancy grids). No ROS, no pybind11.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/two_pointer_shortcut.hpp"

namespace turtlebot_recon::planning {

struct RrtSeed003Params {
  double goal_fraction = 0.3;      // RRT_GOAL_SELECT_FRACTION: share of targets that are the goal
  double step_cells = 4.0;         // RRT_STEP_SCALE: extension step (cells)
  int hitbox_width_cells = 10;     // BOT_WIDTH_CLEARANCE: hit-box extent along x (columns)
  int hitbox_length_cells = 10;    // BOT_LENGTH_CLEARANCE: hit-box extent along y (rows)
  int max_steps = 25000;           // SMAX: sampling steps before giving up
  int max_nodes = 10000;           // NMAX: tree nodes (the start included) before giving up
  bool shortcut = true;            // the two-pointer post-processing
  int occupied_threshold = 65;     // occupancy >= this is an obstacle
  bool unknown_is_obstacle = true; // unknown cells (-1) are obstacles
};

// Throws std::invalid_argument ("<fn>: ...") naming the first bad parameter.
inline void validate(const RrtSeed003Params& p, const std::string& fn) {
  auto fail = [&fn](const std::string& what) { throw std::invalid_argument(fn + ": " + what); };
  if (!(p.goal_fraction >= 0.0 && p.goal_fraction <= 1.0))
    fail("goal_fraction must be in [0, 1], got " + std::to_string(p.goal_fraction));
  if (!(std::isfinite(p.step_cells) && p.step_cells > 0))
    fail("step_cells must be > 0, got " + std::to_string(p.step_cells));
  if (p.hitbox_width_cells < 1 || p.hitbox_length_cells < 1)
    fail("the hit-box must be at least 1 x 1 cells");
  if (p.max_steps < 1 || p.max_nodes < 2) fail("max_steps must be >= 1 and max_nodes >= 2");
}

struct Point2 {
  double x, y;  // cells (x = column, y = row)
};

struct RrtSeed003Result {
  bool found = false;
  std::vector<Point2> tree_path;  // start ... goal through the tree (empty when not found)
  std::vector<Point2> path;       // tree_path after the shortcut (or as is)
  int nodes = 0;                  // tree nodes at the end, the start and the goal included
  int steps = 0;                  // sampling steps taken
  int goal_samples = 0;           // of those, steps whose target was the goal
};

// The obstacle cells of an occupancy grid and the hit-box test on them.
class HitBoxGrid {
 public:
  HitBoxGrid(const std::int8_t* occupancy, int rows, int cols, const RrtSeed003Params& p)
      : rows_(rows), cols_(cols), half_w_(0.5 * p.hitbox_width_cells),
        half_l_(0.5 * p.hitbox_length_cells), sum_(static_cast<size_t>(rows + 1) * (cols + 1), 0) {
    if (rows < 1 || cols < 1) throw std::invalid_argument("rrt_seed003: the grid is empty");
    for (int r = 0; r < rows; ++r) {
      int in_row = 0;
      for (int c = 0; c < cols; ++c) {
        const std::int8_t v = occupancy[static_cast<size_t>(r) * cols + c];
        in_row += (v >= p.occupied_threshold || (v < 0 && p.unknown_is_obstacle)) ? 1 : 0;
        at(r + 1, c + 1) = at(r, c + 1) + in_row;
      }
    }
  }

  int rows() const { return rows_; }
  int cols() const { return cols_; }

  bool obstacle(int row, int col) const {
    if (row < 0 || row >= rows_ || col < 0 || col >= cols_) return true;
    return count(row, col, row, col) > 0;
  }

  // Whether the hit-box centred on p overlaps no obstacle square and stays on the grid.
  bool free_at(Point2 p) const {
    // Cells whose open square meets the open box: floor(lo) .. ceil(hi) - 1 on each axis.
    const int c0 = static_cast<int>(std::floor(p.x - half_w_));
    const int c1 = static_cast<int>(std::ceil(p.x + half_w_)) - 1;
    const int r0 = static_cast<int>(std::floor(p.y - half_l_));
    const int r1 = static_cast<int>(std::ceil(p.y + half_l_)) - 1;
    if (r0 < 0 || c0 < 0 || r1 >= rows_ || c1 >= cols_) return false;
    return count(r0, c0, r1, c1) == 0;
  }

  // Whether the hit-box stays free while its centre moves along a -> b.
  bool free_along(Point2 a, Point2 b) const {
    const double dx = b.x - a.x, dy = b.y - a.y;
    // The fractions t in (0, 1) where a box edge (x +- half_w, y +- half_l) crosses a grid line.
    events_.assign({0.0, 1.0});
    auto crossings = [this](double from, double delta, double half) {
      if (delta == 0.0) return;
      for (double edge : {from - half, from + half}) {
        const double lo = std::min(edge, edge + delta), hi = std::max(edge, edge + delta);
        for (double k = std::floor(lo) + 1.0; k < hi; k += 1.0) events_.push_back((k - edge) / delta);
      }
    };
    crossings(a.x, dx, half_w_);
    crossings(a.y, dy, half_l_);
    std::sort(events_.begin(), events_.end());
    for (size_t i = 0; i + 1 < events_.size(); ++i) {
      if (events_[i + 1] - events_[i] < 1e-12) continue;  // the same crossing twice
      const double t = 0.5 * (events_[i] + events_[i + 1]);
      if (!free_at({a.x + t * dx, a.y + t * dy})) return false;
    }
    return true;
  }

 private:
  std::int32_t& at(int r, int c) { return sum_[static_cast<size_t>(r) * (cols_ + 1) + c]; }
  std::int32_t at(int r, int c) const { return sum_[static_cast<size_t>(r) * (cols_ + 1) + c]; }
  // Obstacle cells in rows r0..r1, columns c0..c1 (inclusive, on the grid).
  std::int32_t count(int r0, int c0, int r1, int c1) const {
    return at(r1 + 1, c1 + 1) - at(r0, c1 + 1) - at(r1 + 1, c0) + at(r0, c0);
  }

  int rows_, cols_;
  double half_w_, half_l_;
  std::vector<std::int32_t> sum_;       // summed-area table of obstacle cells, (rows+1) x (cols+1)
  mutable std::vector<double> events_;  // free_along's scratch
};

class RrtSeed003 {
 public:
  RrtSeed003(const std::int8_t* occupancy, int rows, int cols, const RrtSeed003Params& p)
      : p_(checked(p)), grid_(occupancy, rows, cols, p_) {}

  const HitBoxGrid& grid() const { return grid_; }

  // Plans start -> goal (cells); the caller has checked that both are on the grid and free.
  RrtSeed003Result plan(Point2 start, Point2 goal, std::uint32_t seed) const {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_int_distribution<int> row_of(0, grid_.rows() - 1), col_of(0, grid_.cols() - 1);
    RrtSeed003Result out;
    std::vector<Node> tree{{start, -1}};
    tree.reserve(static_cast<size_t>(p_.max_nodes));
    int reached = -1;
    while (out.steps < p_.max_steps && static_cast<int>(tree.size()) < p_.max_nodes) {
      ++out.steps;
      // 1. target
      Point2 target;
      if (unit(rng) < p_.goal_fraction) {
        target = goal;
        ++out.goal_samples;
      } else {
        target = {col_of(rng) + 0.5, row_of(rng) + 0.5};
      }
      // 2. nearest node
      const int near = nearest(tree, target);
      const Point2 from = tree[near].at;
      const double dx = target.x - from.x, dy = target.y - from.y, d = std::hypot(dx, dy);
      if (d == 0.0) continue;
      // 3. a fixed step toward the target
      const Point2 next{from.x + p_.step_cells * dx / d, from.y + p_.step_cells * dy / d};
      // 4. valid node and connection
      if (!grid_.free_at(next) || !grid_.free_along(from, next)) continue;
      tree.push_back({next, near});
      // 5. the goal within one step (a node itself, within max_nodes)
      if (static_cast<int>(tree.size()) < p_.max_nodes &&
          std::hypot(goal.x - next.x, goal.y - next.y) <= p_.step_cells &&
          grid_.free_along(next, goal)) {
        tree.push_back({goal, static_cast<int>(tree.size()) - 1});
        reached = static_cast<int>(tree.size()) - 1;
        break;
      }
    }
    out.nodes = static_cast<int>(tree.size());
    if (reached < 0) return out;
    out.found = true;
    for (int k = reached; k >= 0; k = tree[k].parent) out.tree_path.push_back(tree[k].at);
    std::reverse(out.tree_path.begin(), out.tree_path.end());
    if (!p_.shortcut) {
      out.path = out.tree_path;
      return out;
    }
    const std::vector<Point2>& v = out.tree_path;
    for (int k : two_pointer_shortcut(static_cast<int>(v.size()),
                                      [&](int i, int j) { return grid_.free_along(v[i], v[j]); }))
      out.path.push_back(v[k]);
    return out;
  }

 private:
  struct Node {
    Point2 at;
    int parent;  // index into the tree; -1 for the start
  };

  static const RrtSeed003Params& checked(const RrtSeed003Params& p) {
    validate(p, "rrt_seed003");
    return p;
  }

  static int nearest(const std::vector<Node>& tree, Point2 target) {
    int best = 0;
    double least = std::numeric_limits<double>::infinity();
    for (int k = 0; k < static_cast<int>(tree.size()); ++k) {
      const double dx = tree[k].at.x - target.x, dy = tree[k].at.y - target.y;
      const double d2 = dx * dx + dy * dy;
      if (d2 < least) least = d2, best = k;
    }
    return best;
  }

  RrtSeed003Params p_;
  HitBoxGrid grid_;
};

}  // namespace turtlebot_recon::planning
