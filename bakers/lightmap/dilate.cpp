#include "bakers/lightmap/dilate.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "bakers/lightmap/texel_neighbourhood.h"

namespace kiln::lightmap {

size_t dilate(image::FloatImage& image, const std::vector<uint8_t>& valid, int padding, const bake::StopCheck& stop) {
  const int w = image.width, h = image.height, channels = image.channels;
  const size_t texels = static_cast<size_t>(w) * h;
  if (valid.size() != texels) {
    throw std::invalid_argument("dilate: the validity map has " + std::to_string(valid.size()) + " entries for a " +
                                std::to_string(w) + "x" + std::to_string(h) + " image");
  }
  // The ring each texel was filled in: 0 for valid texels, -1 while unfilled.
  std::vector<int> ring(texels);
  for (size_t i = 0; i < texels; ++i) ring[i] = valid[i] ? 0 : -1;

  size_t filled = 0;
  std::vector<double> sum(channels);
  std::vector<size_t> fresh;        // texels of the current ring
  std::vector<float> fresh_values;  // their values, written once the ring is complete
  for (int r = 1; r <= padding; ++r) {
    fresh.clear();
    fresh_values.clear();
    for (int y = 0; y < h; ++y) {
      if (y % 64 == 0) stop.check();  // 64 rows of an 8192-texel map: ~10 ms
      for (int x = 0; x < w; ++x) {
        if (ring[static_cast<size_t>(y) * w + x] >= 0) continue;
        std::fill(sum.begin(), sum.end(), 0.0);
        int n = 0;
        for_each_neighbour(x, y, w, h, [&](int nx, int ny) {
          const int nr = ring[static_cast<size_t>(ny) * w + nx];
          if (nr < 0 || nr >= r) return;  // unfilled, or filled in this very ring
          for (int c = 0; c < channels; ++c) sum[c] += image.at(nx, ny, c);
          ++n;
        });
        if (n == 0) continue;
        fresh.push_back(static_cast<size_t>(y) * w + x);
        for (int c = 0; c < channels; ++c) fresh_values.push_back(static_cast<float>(sum[c] / n));
      }
    }
    if (fresh.empty()) break;  // nothing left to grow into
    for (size_t k = 0; k < fresh.size(); ++k) {
      ring[fresh[k]] = r;
      for (int c = 0; c < channels; ++c) image.pixels[fresh[k] * channels + c] = fresh_values[k * channels + c];
    }
    filled += fresh.size();
  }
  return filled;
}

}  // namespace kiln::lightmap
