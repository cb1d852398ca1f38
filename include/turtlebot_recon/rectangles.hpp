// Greedy decomposition of a binary grid into axis-aligned rectangles.
//
// Used by the simulator to turn every solid pixel of a world image into as few
// collision boxes as possible: a 1,000 x 1,700 map becomes a few thousand boxes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace turtlebot_recon {

struct Rect {
  int row;   // first row (image row, top = 0)
  int col;   // first column
  int rows;  // height in cells
  int cols;  // width in cells
};

// Covers exactly the cells where mask != 0 with disjoint rectangles.
// Greedy: scan in row-major order; at the first uncovered cell take the longest
// run to the right, then grow it downwards while the whole run stays uncovered-solid.
std::vector<Rect> merge_rectangles(const std::uint8_t* mask, int rows, int cols);

}  // namespace turtlebot_recon
