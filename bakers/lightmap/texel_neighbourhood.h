// The 3 × 3 neighbourhood of a texel, as dilation and the adaptive sampler's pooled variance read it.
#pragma once

namespace kiln::lightmap {

// Calls f(nx, ny) for every texel of the 3 × 3 neighbourhood of (x, y) in a w × h lightmap (the texel itself
// included) that lies inside the lightmap: rows top to bottom, each left to right.
template <class F>
void for_each_neighbour(int x, int y, int w, int h, const F& f) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
      f(nx, ny);
    }
  }
}

}  // namespace kiln::lightmap
