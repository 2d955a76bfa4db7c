// Cube maps and equirectangular environments: the conventions every envmap output follows, exact texel solid angles,
// seamless bilinear sampling, and area-correct resampling from an equirectangular image.
//
// ## Conventions (embedded in every output's metadata; kCubemapConvention and kEquirectConvention below)
// - World axes: right-handed, +Y is up.
// - Faces in the KTX / OpenGL order: 0 = +X, 1 = −X, 2 = +Y, 3 = −Y, 4 = +Z, 5 = −Z.
// - Orientation: the OpenGL cube-map selection (OpenGL 4.6 core spec table 8.19, table 3.21 in OpenGL 3.x/ES 2.0),
//   which KTX 1 and KTX 2 adopt for cube-map faces. For a direction r = (rx, ry, rz) the face is that of the major
//   axis ma, and with sc, tc from the table
//       face  major axis   sc     tc     ma
//        +X     +rx       −rz    −ry     rx
//        −X     −rx       +rz    −ry     rx
//        +Y     +ry       +rx    +rz     ry
//        −Y     −ry       +rx    −rz     ry
//        +Z     +rz       +rx    −ry     rz
//        −Z     −rz       −rx    −ry     rz
//   the face coordinates are s = (sc/|ma| + 1)/2, t = (tc/|ma| + 1)/2, both in [0, 1].
//   Conversely, with a = 2s − 1 and b = 2t − 1 the (unnormalised) direction of (face, s, t) is
//        +X: ( 1, −b, −a)   −X: (−1, −b,  a)   +Y: ( a,  1,  b)
//        −Y: ( a, −1, −b)   +Z: ( a, −b,  1)   −Z: (−a, −b, −1)
// - Texels: a face of size N holds N × N texels; texel (x, y) covers s ∈ [x/N, (x+1)/N], t ∈ [y/N, (y+1)/N], its
//   centre at s = (x + ½)/N, t = (y + ½)/N. x is the column, y the row, and row y = 0 (t near 0) is stored first, as
//   glTexImage2D and KTX store it; EXR faces are written with that first row as the top row of the picture.
// - Major-axis ties (|rx| = |ry| etc., directions exactly on a cube edge or corner) go to x before y before z, and
//   to the positive face before the negative only through the sign of the chosen component. Both faces agree on
//   such a direction's position (it lies on their shared edge), so the choice does not change any sampled value.
// - Equirectangular images (W × H, first row on top), longitude φ and polar angle θ from +Y:
//       u = ½ + atan2(dir.x, −dir.z) / (2π),   v = acos(dir.y) / π,   column = u·W, row = v·H;
//   so the image centre (u, v) = (½, ½) looks along −Z (the OpenGL camera's forward), u grows towards +X (east when
//   −Z is north), the top row is the zenith +Y and the bottom row the nadir −Y. The inverse is
//       dir = (sin θ sin φ, cos θ, −sin θ cos φ),  φ = 2π(u − ½), θ = πv.
#pragma once

#include <array>
#include <cmath>
#include <functional>
#include <memory>
#include <string_view>
#include <vector>

#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"

namespace kiln::envmap {

inline constexpr std::string_view kCubemapConvention =
    "+Y up, right-handed; faces +X,-X,+Y,-Y,+Z,-Z (KTX/OpenGL order); OpenGL cube-map orientation (GL 4.6 table "
    "8.19): +X(sc=-rz,tc=-ry) -X(sc=+rz,tc=-ry) +Y(sc=+rx,tc=+rz) -Y(sc=+rx,tc=-rz) +Z(sc=+rx,tc=-ry) "
    "-Z(sc=-rx,tc=-ry), s=(sc/|ma|+1)/2, t=(tc/|ma|+1)/2; texel (x,y) centre s=(x+0.5)/N, t=(y+0.5)/N, row t=0 "
    "stored first";
inline constexpr std::string_view kEquirectConvention =
    "u = 0.5 + atan2(dir.x, -dir.z)/(2*pi) (column = u*width), v = acos(dir.y)/pi (row = v*height, row 0 = +Y "
    "zenith); image centre looks along -Z";

enum class Face : int { px = 0, nx = 1, py = 2, ny = 3, pz = 4, nz = 5 };
inline constexpr int kFaceCount = 6;
// File-name suffixes in face order: px, nx, py, ny, pz, nz.
inline constexpr std::array<std::string_view, kFaceCount> kFaceNames = {"px", "nx", "py", "ny", "pz", "nz"};

struct FaceUv {
  int face = 0;    // 0..5 in the order above
  double u = 0.5;  // s of the OpenGL table, in [0, 1]
  double v = 0.5;  // t of the OpenGL table, in [0, 1]
};

// The unnormalised direction (length ≥ 1) of face coordinates (s, t) ∈ [0, 1]²; values outside [0, 1] extend the
// face's plane (used to reach across edges).
Vec3 face_uv_to_direction(int face, double u, double v);
// The unit direction through the centre of texel (x, y) of a face of size `size`.
Vec3 texel_direction(int face, int x, int y, int size);
// The face and (s, t) of a direction (need not be unit). The zero vector (no direction) maps to the centre of +X;
// non-finite components are the caller's to reject. Inline: the prefilter's sampler calls it for every sample.
inline FaceUv direction_to_face_uv(const Vec3& d) {
  const double ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
  FaceUv r;
  double sc, tc, ma;
  if (ax >= ay && ax >= az) {
    // The zero vector has no major axis (ma = 0 would divide by zero): it reads as the centre of +X.
    if (ax == 0.0) return FaceUv{0, 0.5, 0.5};
    ma = ax;
    if (d.x >= 0)
      r.face = 0, sc = -d.z, tc = -d.y;
    else
      r.face = 1, sc = d.z, tc = -d.y;
  } else if (ay >= az) {
    ma = ay;
    if (d.y >= 0)
      r.face = 2, sc = d.x, tc = d.z;
    else
      r.face = 3, sc = d.x, tc = -d.z;
  } else {
    ma = az;
    if (d.z >= 0)
      r.face = 4, sc = d.x, tc = -d.y;
    else
      r.face = 5, sc = -d.x, tc = -d.y;
  }
  r.u = 0.5 * (sc / ma + 1.0);
  r.v = 0.5 * (tc / ma + 1.0);
  return r;
}

// Exact solid angle of texel (x, y) on any face of size `size` (the same for all six faces). With the face at distance
// 1 and plane coordinates (a, b) ∈ [−1, 1]², the solid angle of [0, a] × [0, b] is
//     F(a, b) = atan2(a·b, sqrt(a² + b² + 1)),
// so a texel [a0, a1] × [b0, b1] subtends F(a1, b1) − F(a0, b1) − F(a1, b0) + F(a0, b0) (the derivation behind
// Filament's CubemapUtils::solidAngle and Driscoll's "cubemap texel solid angle").
double texel_solid_angle(int x, int y, int size);
// The same for any rectangle [a0, a1] × [b0, b1] of plane coordinates on a face (sub-texels, whole faces).
double face_rect_solid_angle(double a0, double b0, double a1, double b1);
// texel_solid_angle of every texel of a face, row by row (index y · size + x), bit for bit: built once per size
// from the (size + 1)² corner values F(a, b), which neighbouring texels share, and kept for the process (a bake
// weighs every texel of several cubes of a few sizes by it, six faces each; four arctangents a texel were 7 % of an
// environment bake's CPU).
std::shared_ptr<const std::vector<double>> texel_solid_angles(int size);

// An RGB image in the working space, first row on top; used for equirectangular environments.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<Rgb> pixels;  // pixels[y * width + x]

  RgbImage() = default;
  RgbImage(int w, int h, Rgb fill = Rgb{}) : width(w), height(h), pixels(static_cast<size_t>(w) * h, fill) {}
  Rgb& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
  const Rgb& at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
};

class Cubemap {
 public:
  Cubemap() = default;
  // Throws std::invalid_argument for size < 1.
  explicit Cubemap(int size, Rgb fill = Rgb{});

  int size() const { return size_; }
  Rgb& at(int face, int x, int y) { return faces_[face][static_cast<size_t>(y) * size_ + x]; }
  const Rgb& at(int face, int x, int y) const { return faces_[face][static_cast<size_t>(y) * size_ + x]; }
  std::vector<Rgb>& face(int f) { return faces_[f]; }
  const std::vector<Rgb>& face(int f) const { return faces_[f]; }

  // Texel (x, y) of `face` where x and y may lie one texel outside [0, size): such a texel is read from the face
  // across that edge (the neighbour texel touching the edge at the same place); the missing fourth texel at a cube
  // corner, where only three faces meet, is the average of the three texels that touch the corner.
  Rgb texel_extended(int face, int x, int y) const;

  // Bilinear interpolation in the face's (s, t) between texel centres, reaching across edges and corners through
  // texel_extended, so that the result is continuous over the whole sphere (no seams). `dir` need not be unit.
  Rgb sample_bilinear(const Vec3& dir) const;
  // The texel that contains `dir` (no filtering).
  Rgb sample_nearest(const Vec3& dir) const;

  // ∫ L dω over the sphere with exact texel solid angles.
  Rgb integral() const;

 private:
  int size_ = 0;
  std::array<std::vector<Rgb>, kFaceCount> faces_;
};

// The equirectangular image's (u, v) ∈ [0, 1]² of a direction and back (conventions above). The poles (dir.x = dir.z
// = 0) have no longitude: u = ½ there.
void direction_to_equirect_uv(const Vec3& dir, double& u, double& v);
Vec3 equirect_uv_to_direction(double u, double v);

// Bilinear interpolation of an equirectangular image between pixel centres, wrapping around in longitude and clamping
// at the first and last rows (the poles).
Rgb sample_equirect_bilinear(const RgbImage& equirect, const Vec3& dir);

// Resamples an equirectangular image into a cube of `size`: each texel is the solid-angle-weighted mean of k × k
// sub-texel samples (bilinear in the source), each sub-texel weighted by its exact solid angle, with k chosen so that
// sub-texels are no wider than about half a source pixel (k = clamp(ceil(W / (2 size)), 2, 32) unless given). A
// constant image gives that constant. Runs in parallel with TBB. Throws std::invalid_argument on an empty image or
// size < 1.
Cubemap resample_equirect_to_cube(const RgbImage& equirect, int size, int supersampling = 0);

// A cube of `size` whose texels hold radiance(direction of the texel centre): procedural skies and test scenes.
Cubemap cubemap_from(int size, const std::function<Rgb(const Vec3&)>& radiance);

// The cube of half the size (size must be even) whose texels are the solid-angle-weighted means of their 2 × 2
// children, so that integral() is preserved (up to rounding) and a constant stays that constant.
Cubemap downsample_2x(const Cubemap& cube);

}  // namespace kiln::envmap
