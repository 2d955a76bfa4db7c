#include "bakers/scene/texture_sample.h"

#include <cmath>
#include <cstdint>

namespace kiln::scene {

Rgb sample_bilinear(const Texture& t, Point2 uv) {
  if (t.width <= 0 || t.height <= 0 || t.texels.size() != static_cast<size_t>(t.width) * static_cast<size_t>(t.height))
    return Rgb(1.0);
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return t.texels[0];
  // Wrap into [0, 1) first, so huge UVs cannot overflow the texel arithmetic below.
  const double u = uv.x - std::floor(uv.x), v = uv.y - std::floor(uv.y);
  const double x = u * t.width - 0.5, y = v * t.height - 0.5;  // in texel-centre coordinates, ∈ [−0.5, size − 0.5)
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double fx = x - x0, fy = y - y0;
  auto wrap = [](int64_t i, int n) { return static_cast<size_t>(((i % n) + n) % n); };
  const size_t c0 = wrap(static_cast<int64_t>(x0), t.width), c1 = wrap(static_cast<int64_t>(x0) + 1, t.width);
  const size_t r0 = wrap(static_cast<int64_t>(y0), t.height), r1 = wrap(static_cast<int64_t>(y0) + 1, t.height);
  const size_t w = static_cast<size_t>(t.width);
  const Rgb top = t.texels[r0 * w + c0] * (1 - fx) + t.texels[r0 * w + c1] * fx;
  const Rgb bottom = t.texels[r1 * w + c0] * (1 - fx) + t.texels[r1 * w + c1] * fx;
  return top * (1 - fy) + bottom * fy;
}

}  // namespace kiln::scene
