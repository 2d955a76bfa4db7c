// Decoding an uploaded environment (an equirectangular image, or six cube faces) into the working space, with the
// documented rule for texels that are not usable radiance, and the rotation and intensity the job asks for.
//
// ## Formats
// OpenEXR, Radiance HDR (RGBE), PNG and JPEG, recognised by their first bytes (not by a file name). Anything else is
// refused with a message naming what the bytes look like and the formats accepted. OpenImageIO decodes them in
// memory; its headers stay in env_input.cpp.
//
// ## Limits (checked on the header, before any pixel is read or allocated)
// width ≤ 16384, height ≤ 16384, width·height ≤ 2^26 pixels, and the equirectangular shape: width = 2·height ± 1
// (2:1, one column of slack for images cropped or padded by a pixel).
//
// ## Channels and colour
// One channel is grey (copied to R, G and B); two channels are grey + alpha; three or more are R, G, B (+ alpha and
// anything else, ignored). The image's colour space is options.color_space if given, else "lin_rec709" for the float
// formats (EXR, HDR) and "srgb_texture" for the integer formats (PNG, JPEG); the pixels are converted from it to the
// working space (the config's scene_linear role) with ColorConfig::active().
//
// ## The sanitising rule (counted in SanitizeReport; texels = pixels, each counted at most once per kind)
// 1. Before the colour conversion (OpenColorIO's transforms do not define non-finite input), per channel value:
//    NaN → 0; +Inf → the largest finite channel value of the whole image (0 if it has none); −Inf → 0.
//    A texel with any NaN channel counts once in `nan`; one with any ±Inf channel counts once in `inf`.
// 2. After the conversion: any negative channel value → 0 (a texel with one counts once in `negative`); values the
//    conversion made non-finite (none with kiln's config) → 0, counted in `nan`.
// Nothing non-finite or negative ever reaches the image.
//
// ## Rotation and intensity
// rotation_degrees turns the environment about +Y, right-handed (counter-clockwise seen from above): the radiance
// arriving from direction d after the rotation is the input's from R_y(−α)·d, so with α = 90° what the input showed
// towards −Z is seen towards −X. In the equirectangular image this is a shift of the columns: out(u) = in(u + α/360°).
// The rotation is applied when sampling (sample_environment, environment_to_cube), through EnvRotation
// (env_rotation.h); `image` stays unrotated.
// intensity multiplies every value of `image` (applied at decode time); it must be finite and in (0, 1e6].
//
// ## Six faces
// Six square images of the same size N, in the KTX/GL face order +X, −X, +Y, −Y, +Z, −Z, each oriented as
// cubemap.h says (first row of the picture = row t ≈ 0, stored first, as KTX stores it). Each is decoded with the same
// formats, limits (but square instead of 2:1), colour rules and sanitising as an equirectangular image; the
// sanitised counts are summed over the faces. Errors name the face ("face 2 (+Y)"). Rotation about +Y and intensity
// apply as above (the rotation when resampling: faces_to_cube).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {

inline constexpr int kMaxEnvDimension = 16384;
inline constexpr int64_t kMaxEnvPixels = int64_t{1} << 26;
inline constexpr double kMaxEnvIntensity = 1e6;

struct EnvDecodeOptions {
  // Declared colour space of the input (a space or role of the active config); empty = the format's default.
  std::string color_space;
  double rotation_degrees = 0.0;  // about +Y, right-handed; any finite value
  double intensity = 1.0;         // finite, in (0, 1e6]
};

struct SanitizeReport {
  int64_t nan = 0;       // texels with a NaN channel (replaced by 0)
  int64_t inf = 0;       // texels with an infinite channel (+Inf → largest finite value, −Inf → 0)
  int64_t negative = 0;  // texels with a negative channel after colour conversion (replaced by 0)
  int64_t total() const { return nan + inf + negative; }
};

struct EnvironmentInput {
  RgbImage image;  // equirectangular, working space, intensity applied, NOT rotated
  SanitizeReport sanitized;
  std::string format;         // "openexr", "hdr", "png" or "jpeg"
  int width = 0, height = 0;  // of the source image (same as image's)
  std::string color_space;    // the space the pixels were declared in (and converted from)
  std::string working_space;  // the space `image` is in
  double rotation_degrees = 0.0;
  double intensity = 1.0;
};

// Decodes `bytes` as described above. Throws std::invalid_argument for bad options (intensity, rotation, unknown
// colour space) and std::runtime_error, with a message for people, for bytes that are not an accepted image,
// truncated or corrupt files, sizes beyond the limits and images that are not 2:1.
EnvironmentInput decode_environment(const std::string& bytes, const EnvDecodeOptions& options = {});

// The radiance of the (rotated) environment in direction `dir` (need not be unit): bilinear in the image at the
// lookup direction R_y(−α)·dir.
Rgb sample_environment(const EnvironmentInput& env, const Vec3& dir);

// The rotated environment as the equirectangular image it amounts to: the columns shifted by α/360°·W, exactly (a
// permutation of columns) when α is a multiple of 360°/W, else linearly interpolated along each row (the rotation
// moves only longitude, so this is the bilinear lookup of sample_environment at every pixel centre).
RgbImage rotated_equirect(const EnvironmentInput& env);

// The environment resampled into a cube of `size` (resample_equirect_to_cube of rotated_equirect). Throws
// std::invalid_argument for size < 1 or an empty environment.
Cubemap environment_to_cube(const EnvironmentInput& env, int size);

struct CubeFacesInput {
  Cubemap cube;              // the six faces as given, working space, intensity applied, NOT rotated
  SanitizeReport sanitized;  // summed over the faces
  std::string format;        // of face 0 ("+"-joined if the faces differ)
  int face_size = 0;         // N
  std::string color_space;   // declared (the same rule for every face: options, else the format's default)
  std::string working_space;
  double rotation_degrees = 0.0;
  double intensity = 1.0;
};

// The format and size from the header alone (nothing else is read or allocated), with the same checks and errors as
// decode_environment / decode_cube_faces (count, shape, limits, equal sizes): for estimating a bake's memory first.
struct EnvImageHeader {
  std::string format;
  int width = 0, height = 0;  // of the equirectangular image, or of one face
};
EnvImageHeader probe_environment(const std::string& bytes);
EnvImageHeader probe_cube_faces(const std::vector<std::string>& faces);

// Decodes six faces. Throws std::invalid_argument for bad options or a count other than 6, and std::runtime_error
// naming the face for undecodable, non-square, over-large or differently sized faces.
CubeFacesInput decode_cube_faces(const std::vector<std::string>& faces, const EnvDecodeOptions& options = {});

// The (rotated) faces as a cube of `size`: the faces themselves (same size, no rotation), else area-correct
// (downsample_2x by powers of two, or supersampled with exact sub-texel solid angles, reading the source bilinearly
// and seamlessly at R_y(−α)·d). A constant stays exactly constant. Throws std::invalid_argument for size < 1.
Cubemap faces_to_cube(const CubeFacesInput& faces, int size);

}  // namespace kiln::envmap
