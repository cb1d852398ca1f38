#include "turtlebot_recon/rectangles.hpp"

namespace turtlebot_recon {

std::vector<Rect> merge_rectangles(const std::uint8_t* mask, int rows, int cols) {
  std::vector<std::uint8_t> covered(static_cast<size_t>(rows) * cols, 0);
  auto open = [&](int r, int c) {
    const size_t i = static_cast<size_t>(r) * cols + c;
    return mask[i] != 0 && covered[i] == 0;
  };
  std::vector<Rect> out;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (!open(r, c)) continue;
      // 1. Longest run to the right.
      int w = 1;
      while (c + w < cols && open(r, c + w)) ++w;
      // 2. Grow down while the full run is still open.
      int h = 1;
      for (; r + h < rows; ++h) {
        bool full = true;
        for (int k = 0; k < w && full; ++k) full = open(r + h, c + k);
        if (!full) break;
      }
      // 3. Mark covered.
      for (int i = 0; i < h; ++i)
        for (int k = 0; k < w; ++k) covered[static_cast<size_t>(r + i) * cols + c + k] = 1;
      out.push_back({r, c, h, w});
      c += w - 1;
    }
  }
  return out;
}

}  // namespace turtlebot_recon
