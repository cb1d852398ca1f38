// Bresenham's integer line walk between cell centres, shared by the path shortcut
// (grid_search.hpp) and the viewpoint rays (visibility.hpp). A lidar beam between real points
// is traced exactly instead (grid_traversal.hpp).
//
// The line (r0, c0) -> (r1, c1) is walked one cell per step along the major axis (the larger
// of |r1 - r0| and |c1 - c0|), maybe one along the minor axis, both towards the end cell:
// max(|d row|, |d col|) steps, max(|d row|, |d col|) + 1 cells with both ends. Ties (the error
// term exactly halfway) step both axes, so the walk is the same in either direction of
// reading the axes (rows as x or as y); the Python reference is test/conftest.py's bresenham.
//
// A template, not std::function: the visitor is inlined into the loop, as fast as a
// hand-written walk (visible_unknown and shortcut run it per cell).
#pragma once

#include <algorithm>
#include <cstdlib>

namespace turtlebot_recon {

// Whether a walk visits the end cell (the start cell is always visited); grid_traversal.hpp
// takes it too.
enum class LineEnd { kIncluded, kExcluded };

// Calls visit(row, col) for each cell of the Bresenham line (r0, c0) -> (r1, c1), in order
// from (r0, c0), the end cell last or not at all, until visit returns false; returns whether
// every call returned true (true too when no cell is visited: a line from a cell to itself
// without its end).
template <class Visit>
inline bool bresenham_line(int r0, int c0, int r1, int c1, Visit&& visit,
                           LineEnd end = LineEnd::kIncluded) {
  const int ar = std::abs(r1 - r0), ac = std::abs(c1 - c0);
  const int row_step = r1 < r0 ? -1 : 1, col_step = c1 < c0 ? -1 : 1;
  int err = ar - ac, r = r0, c = c0;
  for (int n = std::max(ar, ac) + (end == LineEnd::kIncluded ? 1 : 0); n > 0; --n) {
    if (!visit(r, c)) return false;
    const int e2 = 2 * err;
    if (e2 >= -ac) {  // step in rows
      err -= ac;
      r += row_step;
    }
    if (e2 <= ar) {  // step in columns
      err += ar;
      c += col_step;
    }
  }
  return true;
}

}  // namespace turtlebot_recon
