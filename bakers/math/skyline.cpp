#include "bakers/math/skyline.h"

#include <algorithm>
#include <limits>

namespace kiln {

bool Skyline::find(int w, int h, int& best_x, int& best_y) const {
  best_y = std::numeric_limits<int>::max();
  best_x = 0;
  for (size_t i = 0; i < runs_.size(); ++i) {
    const int x = runs_[i].x;
    if (x + w > size_) break;
    int y = 0;
    for (size_t j = i; j < runs_.size() && runs_[j].x < x + w; ++j) y = std::max(y, runs_[j].y);
    if (y + h <= size_ && y < best_y) best_y = y, best_x = x;
  }
  return best_y != std::numeric_limits<int>::max();
}

void Skyline::place(int x, int y, int w, int h) {
  std::vector<Run> next;
  for (const Run& r : runs_) {
    const int end = r.x + r.w;
    if (end <= x || r.x >= x + w) {
      next.push_back(r);
      continue;
    }
    if (r.x < x) next.push_back({r.x, r.y, x - r.x});
    if (r.x <= x) next.push_back({x, y + h, w});
    if (end > x + w) next.push_back({x + w, r.y, end - (x + w)});
  }
  runs_.clear();
  for (const Run& r : next) {
    if (!runs_.empty() && runs_.back().y == r.y) {
      runs_.back().w += r.w;
    } else {
      runs_.push_back(r);
    }
  }
}

}  // namespace kiln
