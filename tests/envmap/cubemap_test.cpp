// Cube-map conventions, exact texel solid angles, seamless bilinear sampling and equirectangular resampling.
#include "bakers/envmap/cubemap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"
#include "bakers/math/rng.h"

namespace kiln::envmap {
namespace {

// Neumaier's compensated sum, so that the 4π check measures the solid angles and not the summation.
struct CompensatedSum {
  double sum = 0, c = 0;
  void add(double v) {
    const double t = sum + v;
    c += std::fabs(sum) >= std::fabs(v) ? (sum - t) + v : (v - t) + sum;
    sum = t;
  }
  double value() const { return sum + c; }
};

Vec3 random_unit(Pcg32& rng) {
  const double z = 1.0 - 2.0 * rng.uniform(), phi = 2.0 * kPi * rng.uniform();
  const double r = std::sqrt(std::fmax(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

void expect_vec_near(const Vec3& a, const Vec3& b, double tol, const std::string& what) {
  EXPECT_NEAR(a.x, b.x, tol) << what;
  EXPECT_NEAR(a.y, b.y, tol) << what;
  EXPECT_NEAR(a.z, b.z, tol) << what;
}

TEST(CubemapSolidAngle, AllTexelsSumToFourPi) {
  for (int n : {1, 2, 3, 5, 16, 64, 255, 256}) {
    CompensatedSum s;
    for (int f = 0; f < kFaceCount; ++f)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) s.add(texel_solid_angle(x, y, n));
    // The closed form telescopes: the sum is exact up to the rounding of O(n²) atan2 terms of magnitude ≤ π/6,
    // each good to 1 ulp, which random-walks to ~n · 1e-16 ≪ 1e-12 (the brief's bound) for n ≤ 256.
    EXPECT_NEAR(s.value() / (4.0 * kPi), 1.0, 1e-12) << "size " << n;
  }
  // A whole face is a sixth of the sphere (independent of the formula's cancellation).
  EXPECT_NEAR(texel_solid_angle(0, 0, 1), 4.0 * kPi / 6.0, 1e-15);
}

// The shared table is the per-texel function, bit for bit (the bakes that read it must give the same bytes as
// when each texel called the function), and asking again gives the same table.
TEST(CubemapSolidAngle, TheTableOfASizeIsTheFunctionBitForBit) {
  for (int n : {1, 2, 3, 5, 16, 64, 255, 256}) {
    const std::shared_ptr<const std::vector<double>> table = texel_solid_angles(n);
    ASSERT_EQ(table->size(), static_cast<size_t>(n) * n);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        ASSERT_EQ((*table)[static_cast<size_t>(y) * n + x], texel_solid_angle(x, y, n))
            << "size " << n << " texel " << x << "," << y;
    EXPECT_EQ(texel_solid_angles(n), table);
  }
  EXPECT_THROW(texel_solid_angles(0), std::invalid_argument);
}

TEST(CubemapSolidAngle, EachTexelMatchesQuadratureOfTheJacobian) {
  // dω = da db / (1 + a² + b²)^{3/2} on the plane at distance 1. The integrand is analytic (poles at a² + b² = −1),
  // so a 20-point Gauss–Legendre rule per axis is converged to ~1e-16 even for a whole face.
  for (int n : {1, 2, 3, 8, 32}) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const QuadratureRule qa = gauss_legendre(20, 2.0 * x / n - 1.0, 2.0 * (x + 1) / n - 1.0);
        const QuadratureRule qb = gauss_legendre(20, 2.0 * y / n - 1.0, 2.0 * (y + 1) / n - 1.0);
        double ref = 0;
        for (size_t i = 0; i < qa.nodes.size(); ++i)
          for (size_t j = 0; j < qb.nodes.size(); ++j) {
            const double a = qa.nodes[i], b = qb.nodes[j];
            ref += qa.weights[i] * qb.weights[j] / std::pow(1.0 + a * a + b * b, 1.5);
          }
        // Relative 1e-12: the closed form subtracts O(1) atan2 values to get an O(1/n²) area, losing log10(n²)
        // digits: ~3e-13 relative at n = 32, so larger sizes are not held to this bound.
        EXPECT_NEAR(texel_solid_angle(x, y, n) / ref, 1.0, 1e-12) << "size " << n << " texel " << x << "," << y;
      }
    }
  }
}

TEST(CubemapConvention, FaceCentresAndCornersFollowTheOpenGlTable) {
  // Expected directions written out by hand from the OpenGL table (sc, tc per face; s = (sc/|ma|+1)/2, etc.):
  // centre, then (s, t) = (0, 0), (1, 0), (0, 1), (1, 1).
  struct Expect {
    Vec3 centre, c00, c10, c01, c11;
  };
  const Expect table[kFaceCount] = {
      {{1, 0, 0}, {1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {1, -1, -1}},        // +X: sc = −rz, tc = −ry
      {{-1, 0, 0}, {-1, 1, -1}, {-1, 1, 1}, {-1, -1, -1}, {-1, -1, 1}},   // −X: sc = +rz, tc = −ry
      {{0, 1, 0}, {-1, 1, -1}, {1, 1, -1}, {-1, 1, 1}, {1, 1, 1}},        // +Y: sc = +rx, tc = +rz
      {{0, -1, 0}, {-1, -1, 1}, {1, -1, 1}, {-1, -1, -1}, {1, -1, -1}},   // −Y: sc = +rx, tc = −rz
      {{0, 0, 1}, {-1, 1, 1}, {1, 1, 1}, {-1, -1, 1}, {1, -1, 1}},        // +Z: sc = +rx, tc = −ry
      {{0, 0, -1}, {1, 1, -1}, {-1, 1, -1}, {1, -1, -1}, {-1, -1, -1}}};  // −Z: sc = −rx, tc = −ry
  for (int f = 0; f < kFaceCount; ++f) {
    const std::string name(kFaceNames[f]);
    expect_vec_near(face_uv_to_direction(f, 0.5, 0.5), table[f].centre, 0, name + " centre");
    expect_vec_near(face_uv_to_direction(f, 0, 0), table[f].c00, 0, name + " (0,0)");
    expect_vec_near(face_uv_to_direction(f, 1, 0), table[f].c10, 0, name + " (1,0)");
    expect_vec_near(face_uv_to_direction(f, 0, 1), table[f].c01, 0, name + " (0,1)");
    expect_vec_near(face_uv_to_direction(f, 1, 1), table[f].c11, 0, name + " (1,1)");
    // The inverse: the centre, and points just inside each corner (the corners themselves are ties).
    const FaceUv c = direction_to_face_uv(table[f].centre);
    EXPECT_EQ(c.face, f);
    EXPECT_EQ(c.u, 0.5);
    EXPECT_EQ(c.v, 0.5);
    for (double s : {0.01, 0.99})
      for (double t : {0.01, 0.99}) {
        const FaceUv g = direction_to_face_uv(face_uv_to_direction(f, s, t));
        EXPECT_EQ(g.face, f) << name;
        EXPECT_NEAR(g.u, s, 1e-15) << name;
        EXPECT_NEAR(g.v, t, 1e-15) << name;
      }
  }
  // The 1-texel cube's texels look along the axes.
  expect_vec_near(texel_direction(3, 0, 0, 1), {0, -1, 0}, 0, "-Y 1x1");
}

TEST(CubemapConvention, DirectionFaceUvRoundTrip) {
  Pcg32 rng(7);
  for (int i = 0; i < 100000; ++i) {
    const Vec3 d = random_unit(rng);
    const FaceUv f = direction_to_face_uv(d);
    ASSERT_GE(f.u, 0.0);
    ASSERT_LE(f.u, 1.0);
    ASSERT_GE(f.v, 0.0);
    ASSERT_LE(f.v, 1.0);
    // Unit vectors round-trip to a few ulps (a divide, a scale by 2 and a normalisation).
    const Vec3 back = normalize(face_uv_to_direction(f.face, f.u, f.v));
    ASSERT_NEAR(back.x, d.x, 1e-15);
    ASSERT_NEAR(back.y, d.y, 1e-15);
    ASSERT_NEAR(back.z, d.z, 1e-15);
    // Scaling does not change the face or the position.
    const FaceUv g = direction_to_face_uv(d * 37.0);
    ASSERT_EQ(g.face, f.face);
    ASSERT_NEAR(g.u, f.u, 1e-15);
  }
  // Texel centres map back to their own texel.
  for (int n : {1, 4, 9}) {
    for (int f = 0; f < kFaceCount; ++f)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const FaceUv g = direction_to_face_uv(texel_direction(f, x, y, n));
          EXPECT_EQ(g.face, f);
          EXPECT_NEAR(g.u, (x + 0.5) / n, 1e-15);
          EXPECT_NEAR(g.v, (y + 0.5) / n, 1e-15);
        }
  }
  // Singular case: the zero vector reads as the centre of +X rather than dividing by zero.
  const FaceUv z = direction_to_face_uv({0, 0, 0});
  EXPECT_EQ(z.face, 0);
  EXPECT_EQ(z.u, 0.5);
}

Cubemap random_cube(int n, uint64_t seed) {
  Pcg32 rng(seed);
  Cubemap c(n);
  for (int f = 0; f < kFaceCount; ++f)
    for (auto& t : c.face(f)) t = Rgb{rng.uniform(), rng.uniform(), rng.uniform()};
  return c;
}

TEST(CubemapSampling, BilinearReturnsTexelValuesAtCentres) {
  const Cubemap c = random_cube(5, 3);
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < 5; ++y)
      for (int x = 0; x < 5; ++x) {
        const Rgb s = c.sample_bilinear(texel_direction(f, x, y, 5));
        // The centre's (s, t) is reproduced to ~1e-16, so the interpolation weight of the neighbours is ~1e-15.
        EXPECT_NEAR(s.r, c.at(f, x, y).r, 1e-14);
        EXPECT_NEAR(s.b, c.at(f, x, y).b, 1e-14);
        EXPECT_EQ(c.sample_nearest(texel_direction(f, x, y, 5)), c.at(f, x, y));
      }
}

TEST(CubemapSampling, ContinuousAcrossEveryFaceEdgeAndCorner) {
  // Every edge of every face (so each of the 12 cube edges from both sides), along its whole length including the
  // ends at the corners: two points ε apart in plane coordinates, one on each side of the edge.
  for (int n : {1, 2, 3, 8}) {
    const Cubemap c = random_cube(n, 11 + n);
    const double eps = 1e-9;
    for (int f = 0; f < kFaceCount; ++f) {
      for (int edge = 0; edge < 4; ++edge) {
        for (int k = 0; k <= 64; ++k) {
          // The ends stay 1e-6 inside the corner: at the corner itself the in-face point would be a three-way tie.
          const double along = std::clamp(k / 64.0, 1e-6, 1.0 - 1e-6);
          double s_in, t_in, s_out, t_out;
          switch (edge) {
            case 0:
              s_in = eps, s_out = -eps, t_in = t_out = along;
              break;
            case 1:
              s_in = 1 - eps, s_out = 1 + eps, t_in = t_out = along;
              break;
            case 2:
              t_in = eps, t_out = -eps, s_in = s_out = along;
              break;
            default:
              t_in = 1 - eps, t_out = 1 + eps, s_in = s_out = along;
              break;
          }
          const Vec3 d_in = face_uv_to_direction(f, s_in, t_in), d_out = face_uv_to_direction(f, s_out, t_out);
          ASSERT_EQ(direction_to_face_uv(d_in).face, f);
          ASSERT_NE(direction_to_face_uv(d_out).face, f);
          const Rgb a = c.sample_bilinear(d_in), b = c.sample_bilinear(d_out);
          // Texel values lie in [0, 1], so the interpolant's slope is at most ~n per unit of s (texel pitch 1/n,
          // and the neighbour's parametrisation stretches by at most 1 + 1/n): over 2ε that is ≤ 4nε ≈ 3e-8. A
          // seam would be a jump of order 0.1–1.
          const double tol = 4.0 * n * (2 * eps) + 1e-14;
          EXPECT_NEAR(a.r, b.r, tol) << "size " << n << " face " << f << " edge " << edge << " at " << along;
          EXPECT_NEAR(a.g, b.g, tol);
          EXPECT_NEAR(a.b, b.b, tol);
        }
      }
    }
  }
}

TEST(CubemapSampling, ConstantCubeSamplesToTheConstantEverywhere) {
  const Rgb l{0.3, 1.7, 1e4};
  const Cubemap c(4, l);
  Pcg32 rng(5);
  for (int i = 0; i < 10000; ++i) ASSERT_EQ(c.sample_bilinear(random_unit(rng)), l);
}

TEST(Equirect, ConventionAtTheAxes) {
  double u, v;
  direction_to_equirect_uv({0, 0, -1}, u, v);
  EXPECT_DOUBLE_EQ(u, 0.5);
  EXPECT_DOUBLE_EQ(v, 0.5);
  direction_to_equirect_uv({1, 0, 0}, u, v);
  EXPECT_DOUBLE_EQ(u, 0.75);
  direction_to_equirect_uv({-1, 0, 0}, u, v);
  EXPECT_DOUBLE_EQ(u, 0.25);
  direction_to_equirect_uv({0, 0, 1}, u, v);
  EXPECT_DOUBLE_EQ(u, 1.0);  // atan2(+0, −1) = π: +Z is the seam, u = 1 ≡ 0
  direction_to_equirect_uv({0, 1, 0}, u, v);
  EXPECT_EQ(v, 0.0);
  EXPECT_EQ(u, 0.5);  // singular case: the pole has no longitude
  direction_to_equirect_uv({0, -2, 0}, u, v);
  EXPECT_EQ(v, 1.0);
  Pcg32 rng(9);
  for (int i = 0; i < 10000; ++i) {
    const Vec3 d = random_unit(rng);
    direction_to_equirect_uv(d, u, v);
    const Vec3 back = equirect_uv_to_direction(u, v);
    ASSERT_NEAR(back.x, d.x, 1e-14);
    ASSERT_NEAR(back.y, d.y, 1e-14);
    ASSERT_NEAR(back.z, d.z, 1e-14);
  }
}

TEST(Equirect, ConstantResamplesToExactlyThatConstant) {
  const Rgb l{0.25, 3.0, 12345.678};
  const RgbImage img(64, 32, l);
  for (int n : {1, 7, 16}) {
    const Cubemap c = resample_equirect_to_cube(img, n);
    for (int f = 0; f < kFaceCount; ++f)
      for (const Rgb& t : c.face(f)) ASSERT_EQ(t, l);  // bit for bit: the filters are written L0 + Σ w (L − L0)
  }
}

TEST(Equirect, ResamplingPreservesTheIntegralAndTheDirectionOfFeatures) {
  // L = 2 + x + 0.5 y − 0.25 z + 3 x z: ∫ L dω = 8π (the other terms integrate to 0), ∫ L y dω = 0.5 · 4π/3.
  const auto radiance = [](const Vec3& d) { return 2.0 + d.x + 0.5 * d.y - 0.25 * d.z + 3.0 * d.x * d.z; };
  const int w = 512, h = 256;
  RgbImage img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at(x, y) = Rgb{radiance(equirect_uv_to_direction((x + 0.5) / w, (y + 0.5) / h))};
  const int n = 32;
  const Cubemap c = resample_equirect_to_cube(img, n);
  double integral = 0, first_moment_y = 0, max_err = 0;
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const Vec3 d = texel_direction(f, x, y, n);
        const double dw = texel_solid_angle(x, y, n);
        integral += c.at(f, x, y).r * dw;
        first_moment_y += c.at(f, x, y).r * d.y * dw;
        max_err = std::fmax(max_err, std::fabs(c.at(f, x, y).g - radiance(d)));
      }
  // Bilinear interpolation of a smooth function at pixel pitch Δ = π/256 has error ≲ Δ² max|L''|/8 ≈ 6e-5 · 4;
  // the sub-texel mean is exactly area-weighted, so the integral carries only that error: 1e-4 relative.
  EXPECT_NEAR(integral / (8.0 * kPi), 1.0, 1e-4);
  // The texel mean differs from the value at the centre by about (texel width)² |∇²L| / 24: width ≤ 2/32 rad, and
  // the spherical Laplacian of the l = 1 terms is −2 L₁ (|·| ≤ 2.3) and of 3xz is −18 xz (|·| ≤ 9), so ≲ 1.8e-3;
  // with the bilinear error (~2e-4) and the texel's non-square shape near corners, 3e-3.
  EXPECT_NEAR(first_moment_y / (0.5 * 4.0 * kPi / 3.0), 1.0, 3e-3);
  EXPECT_LT(max_err, 3e-3);
}

TEST(Cubemap, DownsamplePreservesIntegralAndConstants) {
  const Cubemap c = random_cube(16, 21);
  const Cubemap h = downsample_2x(c);
  ASSERT_EQ(h.size(), 8);
  // A parent's solid angle is the sum of its children's, so the integral is preserved up to rounding.
  EXPECT_NEAR(h.integral().g / c.integral().g, 1.0, 1e-13);
  const Rgb l{1.5, 2.5, 0.125};
  const Cubemap k = downsample_2x(Cubemap(6, l));
  for (int f = 0; f < kFaceCount; ++f)
    for (const Rgb& t : k.face(f)) ASSERT_EQ(t, l);
  EXPECT_THROW(downsample_2x(Cubemap(3)), std::invalid_argument);
  EXPECT_THROW(Cubemap(0), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::envmap
