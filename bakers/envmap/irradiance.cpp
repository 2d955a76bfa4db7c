#include "bakers/envmap/irradiance.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <stdexcept>
#include <vector>

#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

// The source flattened once: direction, solid angle and radiance of every texel.
struct SourceTexels {
  std::vector<Vec3> dir;
  std::vector<double> solid_angle;
  std::vector<Rgb> radiance;

  explicit SourceTexels(const Cubemap& cube) {
    const int n = cube.size();
    const size_t count = static_cast<size_t>(kFaceCount) * n * n;
    dir.reserve(count);
    solid_angle.reserve(count);
    radiance.reserve(count);
    const std::vector<double>& omega = *texel_solid_angles(n);
    for (int f = 0; f < kFaceCount; ++f) {
      for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
          dir.push_back(texel_direction(f, x, y, n));
          solid_angle.push_back(omega[static_cast<size_t>(y) * n + x]);
          radiance.push_back(cube.at(f, x, y));
        }
      }
    }
  }

  Rgb convolve(const Vec3& n) const {
    Rgb sum;
    double wsum = 0;
    for (size_t k = 0; k < dir.size(); ++k) {
      const double c = dot(n, dir[k]);
      if (c <= 0) continue;
      const double w = c * solid_angle[k];
      sum += radiance[k] * w;
      wsum += w;
    }
    // Singular case wsum = 0: it cannot happen for a unit n, since the centre of the texel that contains n is at
    // most acos(1/√3) ≈ 54.7° away from it (the whole face of a 1-texel cube), so that texel has n·ω > 0. Guarded
    // anyway rather than dividing by zero.
    if (wsum == 0.0) return Rgb{};
    return sum * (kPi / wsum);
  }
};

}  // namespace

Rgb irradiance_at(const Cubemap& source, const Vec3& normal) {
  if (source.size() < 1) throw std::invalid_argument("irradiance_at: empty source cubemap");
  const double len = length(normal);
  // The zero vector has no hemisphere.
  if (len == 0.0) return Rgb{};
  return SourceTexels(source).convolve(normal / len);
}

Cubemap irradiance_cubemap(const Cubemap& source, int out_size) {
  if (out_size < 1) throw std::invalid_argument("irradiance_cubemap: out_size must be at least 1");
  if (source.size() < 1) throw std::invalid_argument("irradiance_cubemap: empty source cubemap");
  const SourceTexels texels(source);
  Cubemap out(out_size);
  const int per_face = out_size * out_size;
  tbb::parallel_for(tbb::blocked_range<int>(0, kFaceCount * per_face), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i != r.end(); ++i) {
      const int face = i / per_face, rest = i % per_face, y = rest / out_size, x = rest % out_size;
      out.at(face, x, y) = texels.convolve(texel_direction(face, x, y, out_size));
    }
  });
  return out;
}

}  // namespace kiln::envmap
