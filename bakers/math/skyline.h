// A skyline bottom-left rectangle packer: the heights of the columns in use of a square bin, as runs of equal height,
// left to right. The atlas packer (bakers/lightmap/atlas_pack.h) places instances' charts in pages with it, and the
// lightmap-UV generator (bakers/uvgen/chart_pack.h) places a mesh's charts in its UV square.
#pragma once

#include <vector>

namespace kiln {

class Skyline {
 public:
  explicit Skyline(int size) : size_(size), runs_{{0, 0, size}} {}

  // The lowest, then leftmost, position of a w × h rectangle; false when there is none.
  bool find(int w, int h, int& best_x, int& best_y) const;
  // Marks the w × h rectangle at (x, y) as used (a position find() returned).
  void place(int x, int y, int w, int h);

 private:
  struct Run {
    int x, y, w;
  };
  int size_;
  std::vector<Run> runs_;
};

}  // namespace kiln
