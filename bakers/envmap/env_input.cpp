#include "bakers/envmap/env_input.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>


#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "bakers/envmap/env_rotation.h"
#include "bakers/image/color.h"
#include "bakers/image/image_format.h"
#include "bakers/image/image_reader.h"
#include "bakers/image/oiio_memory.h"
#include "bakers/image/reader_bytes.h"

namespace kiln::envmap {
namespace {

constexpr const char* kAccepted = image::kAcceptedImageFormats;
using Format = image::ImageFormat;

std::string dims(int64_t w, int64_t h) { return std::to_string(w) + "x" + std::to_string(h); }

void check_options(const EnvDecodeOptions& o) {
  if (!std::isfinite(o.intensity) || !(o.intensity > 0.0) || o.intensity > kMaxEnvIntensity) {
    throw std::invalid_argument("decode_environment: intensity " + std::to_string(o.intensity) +
                                " is out of range; it must be a finite number in (0, 1e6] (1 keeps the image as is)");
  }
  if (!std::isfinite(o.rotation_degrees)) {
    throw std::invalid_argument("decode_environment: rotation_degrees must be a finite number of degrees about +Y");
  }
}

void check_color_space(const image::ColorConfig& cfg, const std::string& space) {
  if (cfg.has_space(space)) return;
  std::string known;
  for (const auto& s : cfg.spaces()) known += (known.empty() ? "" : ", ") + s;
  throw std::invalid_argument("decode_environment: colour space '" + space + "' is not in " + cfg.source() +
                              "; declare one of: " + known);
}

enum class Shape { equirect, square };

void check_size(int w, int h, int depth, const Format& f, const std::string& who, Shape shape) {
  if (w < 1 || h < 1 || depth != 1) {
    throw std::runtime_error(who + ": the " + f.name + " header describes an empty or volumetric image (" + dims(w, h) +
                             ", depth " + std::to_string(depth) + "); an environment is a flat image");
  }
  if (w > kMaxEnvDimension || h > kMaxEnvDimension || int64_t{w} * h > kMaxEnvPixels) {
    throw std::runtime_error(who + ": the " + f.name + " image is " + dims(w, h) +
                             ", larger than the limits (each side at most " + std::to_string(kMaxEnvDimension) +
                             ", at most " + std::to_string(kMaxEnvPixels) +
                             " pixels, e.g. 8192x4096); downscale it before uploading");
  }
  if (shape == Shape::equirect && std::abs(int64_t{w} - 2 * int64_t{h}) > 1) {
    throw std::runtime_error(who + ": the " + f.name + " image is " + dims(w, h) +
                             ", not an equirectangular (2:1) environment: width must be twice the height (±1), e.g. " +
                             dims(2 * int64_t{h}, h) + " or " + dims(w, std::max(1, w / 2)) +
                             "; crop or resample it, or upload six cube faces instead");
  }
  if (shape == Shape::square && w != h) {
    throw std::runtime_error(who + ": the " + f.name + " image is " + dims(w, h) +
                             ", not square: a cube face must be N x N (e.g. " + dims(std::min(w, h), std::min(w, h)) +
                             "); crop or resample it");
  }
}

// The per-pixel passes below run in parallel over blocks of this many pixels (a 2048 × 1024 image: 32 blocks).
// Every pixel is independent and the reductions (a maximum, integer counts) do not depend on the order, so the
// results are those of one pass in order.
constexpr size_t kPixelsPerBlock = size_t{1} << 16;

// fn(first, last) over [0, pixels) in blocks, in parallel, summing the SanitizeReport each block returns.
template <class Fn>
SanitizeReport sum_over_blocks(size_t pixels, Fn&& fn) {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, pixels, kPixelsPerBlock), SanitizeReport{},
      [&](const tbb::blocked_range<size_t>& r, SanitizeReport acc) {
        const SanitizeReport block = fn(r.begin(), r.end());
        acc.nan += block.nan, acc.inf += block.inf, acc.negative += block.negative;
        return acc;
      },
      [](SanitizeReport a, const SanitizeReport& b) {
        a.nan += b.nan, a.inf += b.inf, a.negative += b.negative;
        return a;
      });
}

// The largest finite value of the interleaved RGB data (−∞ if none).
float largest_finite(const std::vector<float>& rgb) {
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, rgb.size(), 3 * kPixelsPerBlock), -std::numeric_limits<float>::infinity(),
      [&](const tbb::blocked_range<size_t>& r, float largest) {
        for (size_t i = r.begin(); i != r.end(); ++i)
          if (std::isfinite(rgb[i])) largest = std::max(largest, rgb[i]);
        return largest;
      },
      [](float a, float b) { return std::max(a, b); });
}

// Rule step 1 (see the header): NaN and ±Inf replaced before the colour conversion, counted per texel.
void sanitize_non_finite(std::vector<float>& rgb, SanitizeReport& report) {
  float largest = largest_finite(rgb);
  if (!std::isfinite(largest)) largest = 0.0f;
  const SanitizeReport counts = sum_over_blocks(rgb.size() / 3, [&](size_t first, size_t last) {
    SanitizeReport block;
    for (size_t p = first; p < last; ++p) {
      bool nan = false, inf = false;
      for (int c = 0; c < 3; ++c) {
        float& v = rgb[3 * p + c];
        if (std::isnan(v))
          nan = true, v = 0.0f;
        else if (std::isinf(v))
          inf = true, v = v > 0 ? largest : 0.0f;
      }
      block.nan += nan;
      block.inf += inf;
    }
    return block;
  });
  report.nan += counts.nan;
  report.inf += counts.inf;
}

}  // namespace

namespace {

// The bytes' format, or an error naming what they start with.
const Format& detect_format(const std::string& bytes, const std::string& who, Shape shape) {
  const Format* format = image::detect_image_format(bytes);
  if (!format) {
    throw std::runtime_error(who + ": the " + std::to_string(bytes.size()) +
                             " bytes are not an image kiln reads (they start with " + image::hex_prefix(bytes, 8) +
                             "); upload " + (shape == Shape::equirect ? "an equirectangular " : "a square ") +
                             kAccepted + " file");
  }
  return *format;
}

// The pixels as interleaved RGB floats: the first three channels, or the grey channel repeated (alpha and the rest
// are dropped).
std::vector<float> read_rgb(OIIO::ImageInput& in, const Format& format, const std::string& who) {
  const OIIO::ImageSpec& spec = in.spec();
  const int w = spec.width, h = spec.height, nch = spec.nchannels;
  if (nch < 1) throw std::runtime_error(who + ": the " + format.name + " image has no channels");
  const int take = nch >= 3 ? 3 : 1;
  const size_t pixels = static_cast<size_t>(w) * static_cast<size_t>(h);
  std::vector<float> data(pixels * take);
  if (!in.read_image(0, 0, 0, take, OIIO::TypeDesc::FLOAT, data.data())) {
    throw std::runtime_error(who + ": could not read the pixels of the " + dims(w, h) + " " + format.name +
                             " image (truncated or corrupt?): " + in.geterror() +
                             "; re-export the file and upload it again");
  }
  in.close();
  if (take == 1) {
    std::vector<float> rgb(pixels * 3);
    for (size_t p = 0; p < pixels; ++p) rgb[3 * p] = rgb[3 * p + 1] = rgb[3 * p + 2] = data[p];
    data = std::move(rgb);
  }
  return data;
}

// Rule step 2 for one converted pixel: negatives (and non-finite values) to 0, the rest scaled by the intensity.
Rgb working_radiance(const float* rgb, double intensity, SanitizeReport& counts) {
  bool nan = false, negative = false;
  double c[3];
  for (int k = 0; k < 3; ++k) {
    const double v = rgb[k];
    if (!std::isfinite(v))
      nan = true, c[k] = 0.0;  // cannot happen with kiln's config
    else if (v < 0.0)
      negative = true, c[k] = 0.0;
    else
      c[k] = v * intensity;
  }
  counts.nan += nan;
  counts.negative += negative;
  return {c[0], c[1], c[2]};
}

// env.image from decoded RGB in `space`: non-finite values sanitised, converted to the working space, negatives
// clamped to 0 and scaled by the intensity (the rule of the header), with the counts in env.sanitized.
void to_working_radiance(std::vector<float>& data, const std::string& space, const EnvDecodeOptions& options,
                         EnvironmentInput& env) {
  const image::ColorConfig& cfg = image::ColorConfig::active();
  const size_t pixels = static_cast<size_t>(env.width) * static_cast<size_t>(env.height);
  sanitize_non_finite(data, env.sanitized);
  env.image = RgbImage(env.width, env.height);
  const SanitizeReport counts = sum_over_blocks(pixels, [&](size_t first, size_t last) {
    // OpenColorIO's processors convert each pixel on its own and may be applied from several threads.
    if (space != env.working_space) cfg.convert(&data[3 * first], last - first, 3, space, env.working_space);
    SanitizeReport block;
    for (size_t p = first; p < last; ++p)
      env.image.pixels[p] = working_radiance(&data[3 * p], options.intensity, block);
    return block;
  });
  env.sanitized.nan += counts.nan;
  env.sanitized.negative += counts.negative;
}

// Decodes, sanitises and converts one image (see the header); `who` starts every message.
EnvironmentInput decode_image(const std::string& bytes, const EnvDecodeOptions& options, const std::string& who,
                              Shape shape, bool header_only = false) {
  const Format& format = detect_format(bytes, who, shape);
  const image::ColorConfig& cfg = image::ColorConfig::active();
  const std::string space =
      !options.color_space.empty() ? options.color_space : (format.is_float ? "lin_rec709" : "srgb_texture");
  check_color_space(cfg, space);

  std::string storage;
  const std::string& readable = image::reader_bytes(bytes, format, who, storage);
  image::detail::BoundedMemReader proxy(readable.data(), readable.size());
  std::unique_ptr<image::TempImageFile> temp;
  std::unique_ptr<OIIO::ImageInput> in = image::open_image_reader(readable, format, proxy, temp, who);
  const OIIO::ImageSpec& spec = in->spec();
  check_size(spec.width, spec.height, std::max(1, spec.depth), format, who, shape);
  EnvironmentInput env;
  env.format = format.name;
  env.width = spec.width;
  env.height = spec.height;
  if (header_only) return env;
  std::vector<float> data = read_rgb(*in, format, who);
  env.color_space = space;
  env.working_space = cfg.working_space();
  env.rotation_degrees = options.rotation_degrees;
  env.intensity = options.intensity;
  to_working_radiance(data, space, options, env);
  return env;
}

}  // namespace

EnvironmentInput decode_environment(const std::string& bytes, const EnvDecodeOptions& options) {
  check_options(options);
  return decode_image(bytes, options, "decode_environment", Shape::equirect);
}

EnvImageHeader probe_environment(const std::string& bytes) {
  const EnvironmentInput h = decode_image(bytes, {}, "decode_environment", Shape::equirect, true);
  return {h.format, h.width, h.height};
}

namespace {
const char* kSignedFace[kFaceCount] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
std::string face_who(int f) { return "decode_cube_faces: face " + std::to_string(f) + " (" + kSignedFace[f] + ")"; }
void check_face_count(const std::vector<std::string>& faces) {
  if (faces.size() != static_cast<size_t>(kFaceCount)) {
    throw std::invalid_argument("decode_cube_faces: " + std::to_string(faces.size()) +
                                " face images given; a cube needs exactly 6, in the order +X, -X, +Y, -Y, +Z, -Z");
  }
}
void check_face_size(int f, int w, int h, int size0) {
  if (f > 0 && w != size0) {
    throw std::runtime_error(face_who(f) + ": the image is " + dims(w, h) + " but face 0 (+X) is " +
                             dims(size0, size0) + "; all six faces must have the same size");
  }
}
}  // namespace

EnvImageHeader probe_cube_faces(const std::vector<std::string>& faces) {
  check_face_count(faces);
  EnvImageHeader out;
  for (int f = 0; f < kFaceCount; ++f) {
    const EnvironmentInput h = decode_image(faces[f], {}, face_who(f), Shape::square, true);
    check_face_size(f, h.width, h.height, out.width);
    if (f == 0) out = {h.format, h.width, h.height};
  }
  return out;
}

CubeFacesInput decode_cube_faces(const std::vector<std::string>& faces, const EnvDecodeOptions& options) {
  check_options(options);
  check_face_count(faces);
  CubeFacesInput out;
  for (int f = 0; f < kFaceCount; ++f) {
    const std::string who = face_who(f);
    EnvironmentInput img = decode_image(faces[f], options, who, Shape::square);
    check_face_size(f, img.width, img.height, out.face_size);
    if (f == 0) {
      out.face_size = img.width;
      out.format = img.format;
      out.color_space = img.color_space;
      out.working_space = img.working_space;
      out.cube = Cubemap(img.width);
    } else if (img.format != out.format && out.format.find(img.format) == std::string::npos) {
      out.format += "+" + img.format;
    }
    out.sanitized.nan += img.sanitized.nan;
    out.sanitized.inf += img.sanitized.inf;
    out.sanitized.negative += img.sanitized.negative;
    // Row y of the picture (first row on top) is row t = (y + ½)/N of the face: the order glTexImage2D and KTX
    // store (cubemap.h), so pixels copy straight across.
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) out.cube.at(f, x, y) = img.image.at(x, y);
  }
  out.rotation_degrees = options.rotation_degrees;
  out.intensity = options.intensity;
  return out;
}

Rgb sample_environment(const EnvironmentInput& env, const Vec3& dir) {
  return sample_equirect_bilinear(env.image, EnvRotation(env.rotation_degrees).to_image(dir));
}

RgbImage rotated_equirect(const EnvironmentInput& env) {
  const RgbImage& src = env.image;
  const int w = src.width, h = src.height;
  if (w < 1 || h < 1) throw std::invalid_argument("rotated_equirect: the environment is empty");
  // out(x) = in(x + shift), in columns, wrapping around in longitude.
  double shift = std::fmod(env.rotation_degrees / 360.0 * w, static_cast<double>(w));
  if (shift < 0) shift += w;
  const double whole = std::round(shift);
  RgbImage out(w, h);
  if (std::fabs(shift - whole) < 1e-9 * std::max(1, w)) {
    const int k = static_cast<int>(whole) % w;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) out.at(x, y) = src.at((x + k) % w, y);
    }
    return out;
  }
  const int k0 = static_cast<int>(std::floor(shift));
  const double t = shift - k0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const Rgb& a = src.at((x + k0) % w, y);
      const Rgb& b = src.at((x + k0 + 1) % w, y);
      out.at(x, y) = a + (b - a) * t;
    }
  }
  return out;
}

Cubemap environment_to_cube(const EnvironmentInput& env, int size) {
  if (size < 1)
    throw std::invalid_argument("environment_to_cube: size must be at least 1, got " + std::to_string(size));
  if (env.image.width < 1 || env.image.height < 1)
    throw std::invalid_argument("environment_to_cube: empty environment");
  if (std::fmod(env.rotation_degrees, 360.0) == 0.0) return resample_equirect_to_cube(env.image, size);
  return resample_equirect_to_cube(rotated_equirect(env), size);
}

Cubemap faces_to_cube(const CubeFacesInput& faces, int size) {
  if (size < 1) throw std::invalid_argument("faces_to_cube: size must be at least 1, got " + std::to_string(size));
  if (faces.cube.size() < 1) throw std::invalid_argument("faces_to_cube: no faces");
  const Cubemap& src = faces.cube;
  const bool unrotated = std::fmod(faces.rotation_degrees, 360.0) == 0.0;
  // Same size, no rotation: the faces themselves.
  if (unrotated && size == src.size()) return src;
  // Area-correct down by powers of two when possible (a constant stays exact); otherwise supersampled: each output
  // texel is the solid-angle-weighted mean of k × k sub-texels read bilinearly (seamlessly) from the rotated source,
  // k = clamp(ceil(2 N_src / size), 2, 32) so that sub-texels are no wider than half a source texel.
  if (unrotated && size < src.size() && src.size() % size == 0 &&
      ((src.size() / size) & (src.size() / size - 1)) == 0) {
    Cubemap c = src;
    while (c.size() > size) c = downsample_2x(c);
    return c;
  }
  const int k = std::clamp((2 * src.size() + size - 1) / size, 2, 32);
  const EnvRotation rotation(faces.rotation_degrees);
  Cubemap cube(size);
  const double texel = 2.0 / size, sub = texel / k;
  tbb::parallel_for(tbb::blocked_range<int>(0, kFaceCount * size), [&](const tbb::blocked_range<int>& rows) {
    for (int row = rows.begin(); row != rows.end(); ++row) {
      const int face = row / size, y = row % size;
      for (int x = 0; x < size; ++x) {
        Rgb first, delta;
        double wsum = 0;
        for (int j = 0; j < k; ++j)
          for (int i = 0; i < k; ++i) {
            const double sa0 = -1.0 + x * texel + i * sub, sb0 = -1.0 + y * texel + j * sub;
            const double w = face_rect_solid_angle(sa0, sb0, sa0 + sub, sb0 + sub);
            const Vec3 d = face_uv_to_direction(face, 0.5 * (sa0 + 0.5 * sub + 1.0), 0.5 * (sb0 + 0.5 * sub + 1.0));
            const Rgb v = src.sample_bilinear(rotation.to_image(d));
            // The weighted mean as L0 + Σ w (L − L0) / Σ w: exactly L0 when all samples are equal.
            if (i == 0 && j == 0) first = v;
            delta += (v - first) * w;
            wsum += w;
          }
        cube.at(face, x, y) = first + delta / wsum;
      }
    }
  });
  return cube;
}

}  // namespace kiln::envmap
