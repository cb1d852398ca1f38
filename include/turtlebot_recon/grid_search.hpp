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
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/bresenham.hpp"
#include "turtlebot_recon/costmap.hpp"
#include "turtlebot_recon/two_pointer_shortcut.hpp"

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

// The open list: a radix heap (Ahuja, Mehlhorn, Orlin & Tarjan 1990) of (f, cell) entries.
//
// Keys. A radix heap needs monotone keys: nothing pushed below the last key popped. A* with a
// consistent heuristic pops f in non-decreasing order (Dijkstra too), and the IEEE-754 bit
// pattern of a non-negative double, read as an unsigned 64-bit integer, orders like the
// number; so the heap orders the bit patterns of f, exactly.
//
// Buckets. An entry's bucket depends on where its key first differs from last_, the key
// popped last: bucket "due" if it equals it, else (level, digit), level being the 4-bit digit
// of the highest differing bit and digit the key's value there (above last_'s). Every key of
// bucket (level, digit) is then below every key of (level, a higher digit) and of any higher
// level, so the lowest non-empty bucket (a bit scan) holds the lowest key. pop() takes from
// "due"; when that is empty it pops the lowest bucket's minimum, which becomes last_, and
// moves the bucket's other entries down to the lower levels that now fit them. On the
// benchmark maps an entry moves about twice, against a binary heap's log2(size) sift steps
// per pop (4-bit digits: ~10% faster there than 1-bit ones).
//
// Lazy deletion. A cell pushed again with a lower f leaves its old entry behind. Once the cell
// is closed (is_closed(cell)) that entry is stale: the heap drops it when it comes to move it,
// which saves most of the moves and pops of stale entries (nearly half of all entries on the
// benchmark maps), and the caller skips the few it still pops.
template <class IsClosed>
class OpenList {
 public:
  explicit OpenList(IsClosed is_closed) : is_closed_(is_closed) {}

  bool empty() const { return size_ == 0; }

  void push(double f, std::int32_t cell) {
    // astar()'s tie-break leaves the heuristic inconsistent by a relative 1e-9, so f may fall
    // that far below the last key popped: such an entry is due now.
    const std::uint64_t key = std::max(bits_of(f), last_);
    add({key, cell});
    ++size_;
  }

  // Removes an entry with the lowest f and returns its cell.
  std::int32_t pop() {
    --size_;
    if (due_.size > 0) return due_.data[--due_.size].cell;
    const int lowest = lowest_bucket();
    Bucket& from = buckets_[lowest];
    non_empty_[lowest / 64] &= ~(std::uint64_t{1} << (lowest % 64));
    std::uint32_t min = 0;
    for (std::uint32_t i = 1; i < from.size; ++i)
      if (from.data[i].key < from.data[min].key) min = i;
    const Entry top = from.data[min];
    from.data[min] = from.data[--from.size];
    last_ = top.key;
    for (std::uint32_t i = 0; i < from.size; ++i) {
      if (is_closed_(from.data[i].cell)) --size_;  // stale
      else add(from.data[i]);
    }
    from.size = 0;
    return top.cell;
  }

 private:
  struct Entry {
    std::uint64_t key;
    std::int32_t cell;
  };
  // A growable array of entries; std::vector's push_back costs ~10% more here.
  struct Bucket {
    std::unique_ptr<Entry[]> data;
    std::uint32_t size = 0, capacity = 0;
    void push(const Entry& e) {
      if (size == capacity) grow();
      data[size++] = e;
    }
    void grow() {
      capacity = capacity == 0 ? 16 : 2 * capacity;
      std::unique_ptr<Entry[]> bigger(new Entry[capacity]);
      std::copy(data.get(), data.get() + size, bigger.get());
      data = std::move(bigger);
    }
  };
  static constexpr int kDigitBits = 4, kDigits = 1 << kDigitBits;
  static constexpr int kLevels = 64 / kDigitBits;

  static std::uint64_t bits_of(double f) {
    std::uint64_t key;
    std::memcpy(&key, &f, sizeof key);
    return key;
  }

  // Puts e (key >= last_) in its bucket.
  void add(const Entry& e) {
    if (e.key == last_) {
      due_.push(e);
      return;
    }
    const int bit = 63 - __builtin_clzll(e.key ^ last_);
    const int level = bit / kDigitBits;
    const int digit = static_cast<int>(e.key >> (level * kDigitBits)) & (kDigits - 1);
    const int bucket = level * kDigits + digit;
    buckets_[bucket].push(e);
    non_empty_[bucket / 64] |= std::uint64_t{1} << (bucket % 64);
  }

  // The lowest non-empty bucket (some is, as size_ > 0 and due_ is empty).
  int lowest_bucket() const {
    int word = 0;
    while (non_empty_[word] == 0) ++word;
    return 64 * word + __builtin_ctzll(non_empty_[word]);
  }

  IsClosed is_closed_;
  Bucket due_;                                           // keys equal to last_
  std::array<Bucket, kLevels * kDigits> buckets_;        // (level, digit), level-major
  std::array<std::uint64_t, kLevels * kDigits / 64> non_empty_{};  // bit per bucket
  std::uint64_t last_ = 0;                               // the key popped last
  size_t size_ = 0;                                      // entries, stale ones included
};

// A bucket queue for Dijkstra (Dial 1969) where every edge costs at least `width` (> 0):
// a key goes to bucket floor(key / width) of a ring of them. Popping empties the lowest
// bucket in any order, which is exact: a state in bucket b has g < (b + 1) width, so every
// edge out of it, and out of any later state, ends in a later bucket; nothing popped later
// can lower a key of bucket b. `span` bounds how far above the lowest key any key pushed
// lies (the costliest edge, or the spread of the start keys), which sizes the ring. O(1) per
// push and pop, where a heap pays a sift; used by cost_to_come, which has no heuristic.
// Lazy deletion as OpenList: the caller skips the states it pops closed.
class BucketQueue {
 public:
  BucketQueue(double width, double span)
      : width_(width), ring_(static_cast<size_t>(std::ceil(span / width)) + 2) {}

  bool empty() const { return size_ == 0; }

  void push(double key, std::int32_t state) {
    const auto bucket = static_cast<std::int64_t>(std::floor(key / width_));
    if (size_ == 0 || bucket < current_) current_ = bucket;  // only before the first pop
    if (bucket - current_ >= static_cast<std::int64_t>(ring_.size()))
      throw std::logic_error("BucketQueue: a key beyond the ring's span");
    ring_[static_cast<size_t>(bucket) % ring_.size()].push_back(state);
    ++size_;
  }

  std::int32_t pop() {
    std::vector<std::int32_t>* b = &ring_[static_cast<size_t>(current_) % ring_.size()];
    while (b->empty()) b = &ring_[static_cast<size_t>(++current_) % ring_.size()];
    const std::int32_t state = b->back();
    b->pop_back();
    --size_;
    return state;
  }

 private:
  double width_;
  std::vector<std::vector<std::int32_t>> ring_;
  std::int64_t current_ = 0;  // the lowest bucket that may hold a key
  size_t size_ = 0;
};

struct GridPath {
  std::vector<Cell> cells;  // start ... goal; empty when the goal is unreachable
  double cost = std::numeric_limits<double>::infinity();
};

// One search over one costmap (one object per call from Python). It works on its own copy of
// the grid with a ring of impassable cells around it, so that every cell it expands has its 8
// neighbours in memory and the neighbour loop needs no bounds checks: grid cell (r, c) is
// padded index (r + 1) * stride + c + 1, stride = cols + 2. It keeps 10 bytes per cell (g, a
// class byte, the move that reached the cell), so that the cells around the frontier of a
// search on a large map stay in cache.
class GridSearch {
 public:
  // cost: row-major (rows, cols) costmap; visits: same shape or nullptr (no penalty).
  GridSearch(const std::uint8_t* cost, const std::int32_t* visits, int rows, int cols,
             const CostModel& model, const std::string& fn)
      : cost_(cost), rows_(rows), cols_(cols), model_(model), fn_(fn) {
    validate(model, fn);
    if ((static_cast<long long>(rows) + 2) * (static_cast<long long>(cols) + 2) >= (1LL << 31))
      throw std::invalid_argument(fn_ + ": grid too large (more than 2^31 cells)");
    stride_ = cols + 2;
    // Factor of a step's length for entering a cell of each class (visits aside); +inf for
    // kClosed and kImpassable, which are never entered.
    weight_of_class_.fill(std::numeric_limits<double>::infinity());
    for (int e = 0; e < kClosed; ++e) weight_of_class_[e] = 1.0 + model_.cost_weight * e / 252.0;
    // A cell's class: its effective cost (the costmap value; unknown_cost for unknown cells)
    // if it may be entered, else kImpassable. Written as a select so that it vectorises.
    const int lethal = model_.lethal_cost;
    const std::uint8_t unknown =
        model_.unknown_cost < 0 ? kImpassable : static_cast<std::uint8_t>(model_.unknown_cost);
    const size_t padded = static_cast<size_t>(rows + 2) * static_cast<size_t>(stride_);
    class_.assign(padded, kImpassable);
    if (visits != nullptr) visits_.assign(padded, 0);
    for (int r = 0; r < rows; ++r) {
      const std::uint8_t* in = cost + static_cast<size_t>(r) * cols;
      std::uint8_t* out = &class_[index(Cell{r, 0})];
      for (int c = 0; c < cols; ++c)
        out[c] = in[c] < lethal ? in[c] : in[c] == kNoInformation ? unknown : kImpassable;
      if (visits == nullptr) continue;
      const std::int32_t* v = visits + static_cast<size_t>(r) * cols;
      for (int c = 0; c < cols; ++c) {
        if (v[c] < 0)
          throw std::invalid_argument(fn_ + ": visits must be >= 0, found " +
                                      std::to_string(v[c]) + " at " + to_string(Cell{r, c}));
        visits_[index(Cell{r, c})] = v[c];
      }
    }
    const double diag = std::sqrt(2.0) * model_.resolution_m, straight = model_.resolution_m;
    // Moves 0-3 are orthogonal; diagonal k (4-7) is allowed only if both of its orthogonal
    // components, moves kOrthA[k - 4] and kOrthB[k - 4], are passable (no corner cutting).
    moves_ = {{{+1, 0, straight}, {-1, 0, straight}, {0, +1, straight}, {0, -1, straight},
               {+1, +1, diag}, {+1, -1, diag}, {-1, +1, diag}, {-1, -1, diag}}};
    for (int k = 0; k < 8; ++k) offset_[k] = moves_[k].dr * stride_ + moves_[k].dc;
    g_.assign(padded, std::numeric_limits<double>::infinity());
    // Written when a cell's g improves and read only back from the goal: left uninitialised,
    // so that the pages of cells the search never reaches are never touched.
    reached_by_.reset(new std::uint8_t[padded]);
  }

  // Throws std::invalid_argument if `c` (called `what`: "start" or "goal") is off the grid or
  // impassable, e.g. "astar: start (3, 4) is in lethal cost 254 (>= lethal_cost 253)".
  void check_endpoint(const char* what, Cell c) const {
    const std::string head = fn_ + ": " + what + " " + to_string(c);
    if (c.row < 0 || c.row >= rows_ || c.col < 0 || c.col >= cols_)
      throw std::invalid_argument(head + " is outside the " + std::to_string(rows_) + " x " +
                                  std::to_string(cols_) + " grid");
    const int v = cost_[static_cast<size_t>(c.row) * cols_ + c.col];
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
    // It takes padded coordinates; their offset of 1 cancels in the differences.
    const double straight = (1.0 + 1e-9) * model_.resolution_m;
    const double diag_extra = (std::sqrt(2.0) - 1.0) * straight;
    const int goal_r = goal.row + 1, goal_c = goal.col + 1;
    auto octile = [=](int r, int c) {
      const int dr = std::abs(r - goal_r), dc = std::abs(c - goal_c);
      return straight * std::max(dr, dc) + diag_extra * std::min(dr, dc);
    };
    GridPath path;
    const int start_idx = index(start), goal_idx = index(goal);
    if (!search(start_idx, goal_idx, octile)) return path;
    // Walk back from the goal, undoing the move that reached each cell.
    for (int i = goal_idx;; i -= offset_[reached_by_[i]]) {
      path.cells.push_back(cell(i));
      if (i == start_idx) break;
    }
    std::reverse(path.cells.begin(), path.cells.end());
    path.cost = g_[goal_idx];
    return path;
  }

  // Dijkstra: cost-to-come from start to every cell (+inf where unreachable or impassable).
  // With targets, the search stops once every target is settled (or nothing is left to
  // settle): the cells settled by then hold their exact cost, all others +inf. Targets off the
  // grid throw std::invalid_argument; impassable or unreachable ones just never settle.
  void dijkstra(Cell start, float* cost_to_come, const std::vector<Cell>& targets = {}) {
    check_endpoint("start", start);
    if (!targets.empty()) {
      target_.assign(class_.size(), 0);
      for (const Cell& t : targets) {
        if (t.row < 0 || t.row >= rows_ || t.col < 0 || t.col >= cols_)
          throw std::invalid_argument(fn_ + ": target " + to_string(t) + " is outside the " +
                                      std::to_string(rows_) + " x " + std::to_string(cols_) + " grid");
        std::uint8_t& mark = target_[index(t)];
        targets_left_ += mark == 0;
        mark = 1;
      }
    }
    search(index(start), -1, [](int, int) { return 0.0; });
    constexpr float kInf = std::numeric_limits<float>::infinity();
    for (int r = 0; r < rows_; ++r) {
      const size_t i0 = index(Cell{r, 0});
      float* out = cost_to_come + static_cast<size_t>(r) * cols_;
      for (int c = 0; c < cols_; ++c)
        out[c] = class_[i0 + c] == kClosed ? static_cast<float>(g_[i0 + c]) : kInf;
    }
  }

 private:
  struct Move {
    int dr, dc;
    double length_m;
  };
  static constexpr std::array<int, 4> kOrthA = {0, 0, 1, 1};  // row part of diagonals 4..7
  static constexpr std::array<int, 4> kOrthB = {2, 3, 2, 3};  // column part
  // Cell classes above the effective costs (0..253: lethal_cost may be 254) of the cells that
  // may be entered: a closed cell (passable for the corner rule, never entered again) and one
  // that cannot be entered (an obstacle, unknown space when forbidden, the border).
  static constexpr std::uint8_t kClosed = 254;
  static constexpr std::uint8_t kImpassable = 255;

  int index(Cell c) const { return (c.row + 1) * stride_ + c.col + 1; }
  Cell cell(int i) const { return {i / stride_ - 1, i % stride_ - 1}; }

  template <class Heuristic>
  bool search(int start, int goal, Heuristic h) {
    return visits_.empty() ? search<false>(start, goal, h) : search<true>(start, goal, h);
  }

  // Best-first search from start (padded indices). Stops when goal (>= 0) is closed; with
  // goal = -1 and h = 0 it is Dijkstra over the whole grid. h takes padded coordinates.
  // kVisits: whether entry factors include the visit penalty. Returns whether the goal was
  // reached.
  template <bool kVisits, class Heuristic>
  bool search(int start, int goal, Heuristic h) {
    OpenList open([this](std::int32_t i) { return class_[i] == kClosed; });
    g_[start] = 0.0;
    open.push(h(start / stride_, start % stride_), start);
    while (!open.empty()) {
      // 1. Pop the open node n with the lowest f = g + h.
      const std::int32_t n = open.pop();
      // 2. Lazy deletion: skip a stale entry, left behind when n was pushed again with a
      //    lower g and has been closed since (the open list drops most of them itself).
      if (class_[n] == kClosed) continue;
      class_[n] = kClosed;
      // 3. Goal test: g(goal) is optimal once the goal is closed; likewise the last target.
      if (n == goal) return true;
      if (targets_left_ > 0 && target_[n] != 0 && --targets_left_ == 0) return true;
      // 4. Expand n: relax every neighbour b, g(b) = min(g(b), g(n) + L * factor(b)).
      const int r = n / stride_, c = n % stride_;
      const double g_n = g_[n];
      std::array<std::uint8_t, 8> nb;  // class of each neighbour
      for (int k = 0; k < 8; ++k) nb[k] = class_[n + offset_[k]];
      for (int k = 0; k < 8; ++k) {
        if (nb[k] >= kClosed) continue;  // closed or impassable
        if (k >= 4 && (nb[kOrthA[k - 4]] == kImpassable || nb[kOrthB[k - 4]] == kImpassable))
          continue;  // it would cut a corner
        const int b = n + offset_[k];
        double factor = weight_of_class_[nb[k]];
        if constexpr (kVisits) factor += model_.visit_sensitivity * visits_[b];
        const double g_new = g_n + moves_[k].length_m * factor;
        if (g_new < g_[b]) {
          g_[b] = g_new;
          reached_by_[b] = static_cast<std::uint8_t>(k);
          open.push(g_new + h(r + moves_[k].dr, c + moves_[k].dc), b);
        }
      }
    }
    return false;
  }

  const std::uint8_t* cost_;  // the caller's costmap, for check_endpoint's messages
  int rows_, cols_, stride_;
  CostModel model_;
  std::string fn_;
  std::array<double, 256> weight_of_class_{};
  std::array<Move, 8> moves_{};
  std::array<int, 8> offset_{};  // padded index offset of each move
  // Per padded cell:
  std::vector<std::uint8_t> class_;   // effective cost 0..253, kClosed or kImpassable
  std::vector<std::int32_t> visits_;  // visit counts; empty without a visit penalty
  std::vector<double> g_;             // cost to come, +inf until reached
  std::unique_ptr<std::uint8_t[]> reached_by_;  // the move k by which g was reached
  std::vector<std::uint8_t> target_;  // 1 at dijkstra's targets; empty without targets
  int targets_left_ = 0;              // targets not settled yet
};

// Line-of-sight shortcut of a grid path (two_pointer_shortcut.hpp: seed 001's refinePath, seed
// 003's two-pointer shortcut). From waypoint i, keep the farthest later index j whose
// Bresenham line i -> j stays, after its first cell, on cells with cost < lethal_cost and <=
// the highest cost of the path cells i+1..j (so a shortcut never runs closer to obstacles than
// the path already did); continue from j. Cell i itself is left out of both: a path that starts next to a wall (the
// robot stands there) would otherwise license a line along the wall at that cost, where the
// path itself leaves the wall at once.
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

  // ceiling[j]: the highest cost a line i -> j may cross (the path cells i+1..j's highest),
  // for the i it was last filled for
  std::vector<int> ceiling(n);
  int ceiling_of = -1;
  auto connects = [&](int i, int j) {
    if (ceiling_of != i) {
      int highest = 0;
      for (int k = i + 1; k < n; ++k) {
        highest = std::max(highest, cost_at(path[k]));
        ceiling[k] = std::min(highest, lethal_cost - 1);
      }
      ceiling_of = i;
    }
    const int limit = ceiling[j];
    const Cell from = path[i];
    return bresenham_line(from.row, from.col, path[j].row, path[j].col, [&](int r, int c) {
      return (r == from.row && c == from.col) || cost_at(Cell{r, c}) <= limit;
    });
  };
  std::vector<Cell> out;
  for (int k : two_pointer_shortcut(n, connects)) out.push_back(path[k]);
  return out;
}

}  // namespace turtlebot_recon::planning
