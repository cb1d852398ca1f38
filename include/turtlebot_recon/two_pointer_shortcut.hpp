// The two-pointer path shortcut of seed 003 (its post-processing, "1-6 segments"; seed 001's
// refinePath is the same walk): from vertex i keep the farthest later vertex j that i connects
// to, scanning j down from the last, and continue from j. Each kept vertex then reaches no
// farther than the next one kept: no kept vertex connects to the one after next. The planners
// differ only in what "connects" means (a line of cells under a cost ceiling, a hit-box sweep).
#pragma once

#include <vector>

namespace turtlebot_recon::planning {

// The indices kept of a path of n vertices, 0 and n - 1 included; connects(i, j) for i < j,
// called with i in increasing order. Paths of 0-2 vertices are kept whole.
template <class Connects>
std::vector<int> two_pointer_shortcut(int n, Connects&& connects) {
  std::vector<int> kept;
  if (n <= 2) {
    for (int i = 0; i < n; ++i) kept.push_back(i);
    return kept;
  }
  kept.push_back(0);
  int i = 0;
  while (i < n - 1) {
    int j = n - 1;
    while (j > i + 1 && !connects(i, j)) --j;  // the next vertex is always reachable
    kept.push_back(j);
    i = j;
  }
  return kept;
}

}  // namespace turtlebot_recon::planning
