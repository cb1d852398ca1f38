// Exact grid traversal of a segment: Amanatides & Woo, "A Fast Voxel Traversal Algorithm for
// Ray Tracing" (Eurographics 1987), in two dimensions. Used by the ray tracing of
// OccupancyGrid::insert_scan, where a beam starts and ends at real points, not cell centres.
//
// Unlike a Bresenham line between the two cells (bresenham.hpp), which steps diagonally and so
// skips one of the two cells at each diagonal step, this visits every cell the segment passes
// through, 4-connected: |d_row| + |d_col| steps. For a lidar that matters at a wall: the free
// cell in front of the wall cell a beam ends in is always crossed, whatever the beam's angle.
//
// Coordinates are in cells: cell (row, col) is the square col <= x < col + 1, row <= y < row + 1
// (x along columns, y along rows), so a point's cell is (floor(y), floor(x)). When the segment
// passes exactly through a cell corner the walk steps in rows first. The Python reference is
// test/conftest.py's grid_traversal.
#pragma once

#include <cmath>
#include <cstdlib>
#include <limits>

#include "turtlebot_recon/bresenham.hpp"  // LineEnd

namespace turtlebot_recon {

// Walks from the cell of (x0, y0), which is `start`, to the cell of (x1, y1), d_row rows and
// d_col columns away (the caller's floor of the end point, minus the start's). A step in rows
// adds +-row_step to the position and one in columns +-col_step (a flat buffer index, or a
// (row, col) pair). Calls visit(p) for each cell in order, the end cell last or not at all (see
// LineEnd), until visit returns false; returns whether every call returned true. The step
// counts are fixed by d_row and d_col, so rounding in the crossing times can reorder a step at
// a corner but never leave the cells between start and end.
template <class P, class Visit>
inline bool traverse_segment(P start, double x0, double y0, double x1, double y1, int d_row,
                             int d_col, P row_step, P col_step, LineEnd end, Visit&& visit) {
  constexpr double kNever = std::numeric_limits<double>::infinity();
  const double dx = x1 - x0, dy = y1 - y0;
  if (d_row < 0) row_step = -row_step;
  if (d_col < 0) col_step = -col_step;
  // Parameter t in [0, 1] along the segment at which it next crosses a column (row) edge, and
  // the increment of t per column (row).
  double t_col = dx > 0 ? (std::floor(x0) + 1.0 - x0) / dx : dx < 0 ? (std::floor(x0) - x0) / dx : kNever;
  double t_row = dy > 0 ? (std::floor(y0) + 1.0 - y0) / dy : dy < 0 ? (std::floor(y0) - y0) / dy : kNever;
  const double dt_col = dx != 0 ? 1.0 / std::abs(dx) : kNever;
  const double dt_row = dy != 0 ? 1.0 / std::abs(dy) : kNever;
  int rows_left = std::abs(d_row), cols_left = std::abs(d_col);
  P p = start;
  for (int n = rows_left + cols_left + (end == LineEnd::kIncluded ? 1 : 0); n > 0; --n) {
    if (!visit(p)) return false;
    if (cols_left > 0 && (rows_left == 0 || t_col < t_row)) {
      p += col_step;
      t_col += dt_col;
      --cols_left;
    } else if (rows_left > 0) {
      p += row_step;
      t_row += dt_row;
      --rows_left;
    }
  }
  return true;
}

}  // namespace turtlebot_recon
