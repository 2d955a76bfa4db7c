#include "bakers/envmap/cubemap.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "bakers/bake/bounded_cache.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

// a + t (b − a) rather than a (1 − t) + b t: exact when a == b, so that filtering a constant returns it bit for bit.
Rgb lerp_exact(double t, const Rgb& a, const Rgb& b) { return a + (b - a) * t; }

// Solid angle of the rectangle [0, a] × [0, b] on the plane at distance 1 (signed by the signs of a and b).
double corner_area(double a, double b) { return std::atan2(a * b, std::sqrt(a * a + b * b + 1.0)); }

int clamp_index(double v, int n) { return std::clamp(static_cast<int>(std::floor(v)), 0, n - 1); }

// The equirectangular image's column coordinate px = u W − ½ of a direction (x, y, z) (direction_to_equirect_uv),
// from x and −z; the poles (x = z = 0) have no longitude and read u = ½.
double equirect_px(double x, double minus_z, int width) {
  const double u = (x == 0.0 && minus_z == 0.0) ? 0.5 : 0.5 + std::atan2(x, minus_z) * kInv2Pi;
  return u * width - 0.5;
}

// Its row coordinate py = v H − ½ from y and the direction's length.
double equirect_py(double y, double len, int height) {
  return std::acos(std::clamp(y / len, -1.0, 1.0)) * kInvPi * height - 0.5;
}

// Bilinear interpolation at pixel coordinates (px, py), px ∈ [−½, W − ½] (as u ∈ [0, 1] gives), wrapping around
// in longitude and clamping in latitude. A column index lies in [−1, W]: one addition or subtraction wraps it,
// where an integer remainder (a division) per tap was most of the resampling's cost.
Rgb equirect_bilinear_at(const RgbImage& img, double px, double py) {
  const double fx0 = std::floor(px), fy0 = std::floor(py);
  const double tx = px - fx0, ty = py - fy0;
  const int w = img.width;
  const auto wrap = [w](long long x) { return static_cast<int>(x < 0 ? x + w : x >= w ? x - w : x); };
  const int x0 = wrap(static_cast<long long>(fx0)), x1 = wrap(static_cast<long long>(fx0) + 1);
  const int y0 = std::clamp(static_cast<int>(fy0), 0, img.height - 1);
  const int y1 = std::clamp(static_cast<int>(fy0) + 1, 0, img.height - 1);
  return lerp_exact(ty, lerp_exact(tx, img.at(x0, y0), img.at(x1, y0)), lerp_exact(tx, img.at(x0, y1), img.at(x1, y1)));
}

// The equirectangular pixel coordinates of the sub-texel centres of a cube resampled at n sub-texels a side, with
// the arithmetic of direction_to_equirect_uv on face_uv_to_direction's unnormalised directions (so that every read
// is bit for bit sample_equirect_bilinear's), each arctangent, arccosine and square root computed once where faces
// share it. On the side faces (+X, −X, +Z, −Z: x and z are ±1 and ±a, y = −b) the longitude depends on the column
// alone: px is one arctangent per face and column, for the whole cube. Their latitude acos(−b / |d|) is shared by
// +X and −X, whose |d|² sums 1 + b² + a², and by +Z and −Z (a² + b² + 1). The top and bottom faces (a, ±1, ±b) share
// |d|. So a sub-texel position costs 3 square roots, 4 arccosines and 2 arctangents for its six faces, where
// sample_equirect_bilinear costs 6 of each.
class EquirectGrid {
 public:
  struct Row {
    std::array<std::vector<double>, kFaceCount> px, py;  // px is filled for the top and bottom faces only
  };

  EquirectGrid(const RgbImage& img, int n) : width_(img.width), height_(img.height), n_(n) {
    for (int face : {0, 1, 4, 5}) {
      side_px_[face].resize(n);
      for (int col = 0; col < n; ++col) {
        const Vec3 d = face_uv_to_direction(face, (col + 0.5) / n, 0.5);
        side_px_[face][col] = equirect_px(d.x, -d.z, width_);
      }
    }
  }

  // The coordinates of sub-row `sub_row` (0 … n − 1) of every face.
  void row(int sub_row, Row& out) const {
    for (int face = 0; face < kFaceCount; ++face) {
      out.px[face].resize(n_);
      out.py[face].resize(n_);
    }
    const double b = 2.0 * ((sub_row + 0.5) / n_) - 1.0;
    for (int col = 0; col < n_; ++col) {
      const double a = 2.0 * ((col + 0.5) / n_) - 1.0;
      const double len_x = std::sqrt(1.0 + b * b + a * a), len_z = std::sqrt(a * a + b * b + 1.0);
      out.py[0][col] = out.py[1][col] = equirect_py(-b, len_x, height_);
      out.py[4][col] = out.py[5][col] = equirect_py(-b, len_z, height_);
      // +Y is (a, 1, b), −Y is (a, −1, −b).
      const double len_y = std::sqrt(a * a + 1.0 + b * b);
      out.px[2][col] = equirect_px(a, -b, width_);
      out.py[2][col] = equirect_py(1.0, len_y, height_);
      out.px[3][col] = equirect_px(a, b, width_);
      out.py[3][col] = equirect_py(-1.0, len_y, height_);
    }
  }

  double px(int face, int col, const Row& row) const {
    return face == 2 || face == 3 ? row.px[face][col] : side_px_[face][col];
  }

 private:
  int width_, height_, n_;
  std::array<std::vector<double>, kFaceCount> side_px_;
};

}  // namespace

Vec3 face_uv_to_direction(int face, double u, double v) {
  const double a = 2.0 * u - 1.0, b = 2.0 * v - 1.0;
  switch (face) {
    case 0:
      return {1.0, -b, -a};
    case 1:
      return {-1.0, -b, a};
    case 2:
      return {a, 1.0, b};
    case 3:
      return {a, -1.0, -b};
    case 4:
      return {a, -b, 1.0};
    case 5:
      return {-a, -b, -1.0};
    default:
      throw std::invalid_argument("face_uv_to_direction: face must be 0..5");
  }
}

Vec3 texel_direction(int face, int x, int y, int size) {
  return normalize(face_uv_to_direction(face, (x + 0.5) / size, (y + 0.5) / size));
}

double face_rect_solid_angle(double a0, double b0, double a1, double b1) {
  return corner_area(a1, b1) - corner_area(a0, b1) - corner_area(a1, b0) + corner_area(a0, b0);
}

namespace {
// The plane coordinate of grid line i of a face of `size` texels: texel i spans [edge(i), edge(i + 1)].
double edge(int i, int size) { return 2.0 * i / size - 1.0; }
}  // namespace

double texel_solid_angle(int x, int y, int size) {
  return face_rect_solid_angle(edge(x, size), edge(y, size), edge(x + 1, size), edge(y + 1, size));
}

std::shared_ptr<const std::vector<double>> texel_solid_angles(int size) {
  if (size < 1) throw std::invalid_argument("texel_solid_angles: size must be at least 1");
  // A bake uses a handful of sizes (the source's mips, the irradiance source and output, the levels).
  static bake::BoundedCache<int, std::vector<double>> cache(32);
  return cache.get(size, [size] {
    const int n = size + 1;
    std::vector<double> corner(static_cast<size_t>(n) * n);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) corner[static_cast<size_t>(j) * n + i] = corner_area(edge(i, size), edge(j, size));
    const auto c = [&](int i, int j) { return corner[static_cast<size_t>(j) * n + i]; };
    std::vector<double> out(static_cast<size_t>(size) * size);
    // In face_rect_solid_angle's order, so that each value is texel_solid_angle's.
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        out[static_cast<size_t>(y) * size + x] = c(x + 1, y + 1) - c(x, y + 1) - c(x + 1, y) + c(x, y);
    return out;
  });
}

Cubemap::Cubemap(int size, Rgb fill) : size_(size) {
  if (size < 1) throw std::invalid_argument("Cubemap: size must be at least 1");
  for (auto& f : faces_) f.assign(static_cast<size_t>(size) * size, fill);
}

Rgb Cubemap::texel_extended(int face, int x, int y) const {
  const int n = size_;
  const bool x_in = x >= 0 && x < n, y_in = y >= 0 && y < n;
  if (x_in && y_in) return at(face, x, y);
  const int xc = std::clamp(x, 0, n - 1), yc = std::clamp(y, 0, n - 1);
  if (!x_in && !y_in) {
    // Beyond a cube corner: only three texels touch the corner (this face's corner texel and one across each edge),
    // so the fourth tap is their mean. This is symmetric in the three faces, which keeps bilinear sampling continuous
    // across both edges that end at the corner.
    return (at(face, xc, yc) + texel_extended(face, x, yc) + texel_extended(face, xc, y)) / 3.0;
  }
  // One texel beyond one edge: extend this face's plane to that texel's centre (half a texel beyond the edge); its
  // direction falls into the neighbouring face, inside the texel that touches the edge at the same place (the
  // projection moves it by less than half a texel along the edge, and keeps it within the first texel across).
  const Vec3 d = face_uv_to_direction(face, (x + 0.5) / n, (y + 0.5) / n);
  const FaceUv f = direction_to_face_uv(d);
  return at(f.face, clamp_index(f.u * n, n), clamp_index(f.v * n, n));
}

Rgb Cubemap::sample_bilinear(const Vec3& dir) const {
  const FaceUv f = direction_to_face_uv(dir);
  const double px = f.u * size_ - 0.5, py = f.v * size_ - 0.5;
  const double fx0 = std::floor(px), fy0 = std::floor(py);
  const double tx = px - fx0, ty = py - fy0;
  // px, py ∈ [−½, size − ½], so the taps lie in [−1, size]: at most one texel beyond an edge.
  const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  const Rgb top = lerp_exact(tx, texel_extended(f.face, x0, y0), texel_extended(f.face, x0 + 1, y0));
  const Rgb bottom = lerp_exact(tx, texel_extended(f.face, x0, y0 + 1), texel_extended(f.face, x0 + 1, y0 + 1));
  return lerp_exact(ty, top, bottom);
}

Rgb Cubemap::sample_nearest(const Vec3& dir) const {
  const FaceUv f = direction_to_face_uv(dir);
  return at(f.face, clamp_index(f.u * size_, size_), clamp_index(f.v * size_, size_));
}

Rgb Cubemap::integral() const {
  Rgb sum;
  const std::vector<double>& omega = *texel_solid_angles(size_);
  for (int y = 0; y < size_; ++y) {
    for (int x = 0; x < size_; ++x) {
      const double w = omega[static_cast<size_t>(y) * size_ + x];
      for (int f = 0; f < kFaceCount; ++f) sum += at(f, x, y) * w;
    }
  }
  return sum;
}

void direction_to_equirect_uv(const Vec3& dir, double& u, double& v) {
  const double len = length(dir);
  // The zero vector has no direction: it reads as the image centre.
  if (len == 0.0) {
    u = v = 0.5;
    return;
  }
  // The poles have no longitude (atan2(0, ±0) would give 0 or π depending on the sign of zero): u = ½ there.
  u = (dir.x == 0.0 && dir.z == 0.0) ? 0.5 : 0.5 + std::atan2(dir.x, -dir.z) * kInv2Pi;
  v = std::acos(std::clamp(dir.y / len, -1.0, 1.0)) * kInvPi;
}

Vec3 equirect_uv_to_direction(double u, double v) {
  const double phi = 2.0 * kPi * (u - 0.5), theta = kPi * v;
  const double s = std::sin(theta);
  return {s * std::sin(phi), std::cos(theta), -s * std::cos(phi)};
}

Rgb sample_equirect_bilinear(const RgbImage& img, const Vec3& dir) {
  double u, v;
  direction_to_equirect_uv(dir, u, v);
  return equirect_bilinear_at(img, u * img.width - 0.5, v * img.height - 0.5);
}

Cubemap resample_equirect_to_cube(const RgbImage& equirect, int size, int supersampling) {
  if (equirect.width < 1 || equirect.height < 1 ||
      equirect.pixels.size() != static_cast<size_t>(equirect.width) * equirect.height)
    throw std::invalid_argument("resample_equirect_to_cube: empty or inconsistent equirectangular image");
  if (size < 1) throw std::invalid_argument("resample_equirect_to_cube: size must be at least 1");
  // A cube texel at a face centre spans 2/size radians; a source pixel 2π/W. Sub-texels of about half a source pixel
  // need k ≥ 2W / (π size).
  const int k = supersampling > 0 ? supersampling
                                  : std::clamp(static_cast<int>(std::ceil(2.0 * equirect.width / (kPi * size))), 2, 32);
  Cubemap cube(size);
  const EquirectGrid grid(equirect, size * k);
  // The sub-texels' corners lie on one grid of (size k + 1)² points, the same on every face: for each row of texels,
  // the solid angle of the rectangle [0, a] × [0, b] at the grid points it touches (corner_area: two square roots
  // and an arctangent) is computed once for all six faces, and a sub-texel's solid angle is four reads of it
  // (face_rect_solid_angle's sum), where it was four evaluations per sub-texel and face.
  const int n = size * k;
  const double sub = 2.0 / n;
  tbb::parallel_for(tbb::blocked_range<int>(0, size), [&](const tbb::blocked_range<int>& rows) {
    std::vector<double> corner(static_cast<size_t>(k + 1) * (n + 1));
    EquirectGrid::Row coords;
    // Per face and texel of the row: the first sub-texel's value, Σ w (L − L0) and Σ w, in the order (j, i).
    std::array<std::vector<Rgb>, kFaceCount> first, delta;
    std::array<std::vector<double>, kFaceCount> wsum;
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int j = 0; j <= k; ++j)
        for (int i = 0; i <= n; ++i)
          corner[static_cast<size_t>(j) * (n + 1) + i] = corner_area(-1.0 + i * sub, -1.0 + (y * k + j) * sub);
      for (int face = 0; face < kFaceCount; ++face) {
        first[face].assign(size, Rgb{});
        delta[face].assign(size, Rgb{});
        wsum[face].assign(size, 0.0);
      }
      for (int j = 0; j < k; ++j) {
        grid.row(y * k + j, coords);
        const double* c0 = &corner[static_cast<size_t>(j) * (n + 1)];
        const double* c1 = c0 + (n + 1);
        for (int face = 0; face < kFaceCount; ++face)
          for (int x = 0; x < size; ++x)
            for (int i = 0; i < k; ++i) {
              const int col = x * k + i;
              const double w = c1[col + 1] - c1[col] - c0[col + 1] + c0[col];
              const Rgb value = equirect_bilinear_at(equirect, grid.px(face, col, coords), coords.py[face][col]);
              // The weighted mean written as L0 + Σ w (L − L0) / Σ w: exactly L0 when all samples are equal.
              if (j == 0 && i == 0)
                first[face][x] = value;
              else
                delta[face][x] += (value - first[face][x]) * w;
              wsum[face][x] += w;
            }
      }
      for (int face = 0; face < kFaceCount; ++face)
        for (int x = 0; x < size; ++x) cube.at(face, x, y) = first[face][x] + delta[face][x] / wsum[face][x];
    }
  });
  return cube;
}

Cubemap cubemap_from(int size, const std::function<Rgb(const Vec3&)>& radiance) {
  Cubemap c(size);
  for (int f = 0; f < kFaceCount; ++f) {
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) c.at(f, x, y) = radiance(texel_direction(f, x, y, size));
    }
  }
  return c;
}

Cubemap downsample_2x(const Cubemap& cube) {
  const int n = cube.size();
  if (n < 2 || n % 2 != 0) throw std::invalid_argument("downsample_2x: the cube's size must be even");
  const int h = n / 2;
  Cubemap out(h);
  const std::vector<double>& omega = *texel_solid_angles(n);
  tbb::parallel_for(tbb::blocked_range<int>(0, kFaceCount * h), [&](const tbb::blocked_range<int>& rows) {
    for (int row = rows.begin(); row != rows.end(); ++row) {
      const int face = row / h, y = row % h;
      for (int x = 0; x < h; ++x) {
        const Rgb l0 = cube.at(face, 2 * x, 2 * y);
        Rgb delta;
        double wsum = 0;
        for (int j = 0; j < 2; ++j) {
          for (int i = 0; i < 2; ++i) {
            const double w = omega[static_cast<size_t>(2 * y + j) * n + 2 * x + i];
            delta += (cube.at(face, 2 * x + i, 2 * y + j) - l0) * w;
            wsum += w;
          }
        }
        out.at(face, x, y) = l0 + delta / wsum;
      }
    }
  });
  return out;
}

}  // namespace kiln::envmap
