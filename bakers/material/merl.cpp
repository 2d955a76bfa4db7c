#include "bakers/material/merl.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <stdexcept>

#include "bakers/math/constants.h"

namespace kiln::material {
namespace {

constexpr const char* kChannelNames[3] = {"R", "G", "B"};

// MERL files are little-endian (they were written on x86); byte order is fixed here, not left to the host.
template <typename T>
void append_le(std::string& out, T value) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}
template <typename T>
T read_le(const char* p) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
  T value;
  std::memcpy(&value, b, sizeof(T));
  return value;
}

double clamp1(double c) { return std::fmax(-1.0, std::fmin(1.0, c)); }

int truncate_index(double index, int n) {
  // The reader's int cast truncates towards zero; NaN and negative indices land in bin 0.
  if (!(index > 0)) return 0;
  return std::min(n - 1, static_cast<int>(index));
}

// Angles at continuous indices: the inverses of the reader's index maps.
double theta_h_at(double index) { return (index / kMerlThetaH) * (index / kMerlThetaH) * kPiOver2; }
double theta_d_at(double index) { return index / kMerlThetaD * kPiOver2; }
double phi_d_at(double index) { return index / kMerlPhiD * kPi; }

}  // namespace

MerlDirections merl_directions(double theta_h, double theta_d, double phi_d, double phi_h) {
  const double sh = std::sin(theta_h), ch = std::cos(theta_h);
  const double sp = std::sin(phi_h), cp = std::cos(phi_h);
  const Vec3 h{sh * cp, sh * sp, ch};
  const Vec3 d{std::sin(theta_d) * std::cos(phi_d), std::sin(theta_d) * std::sin(phi_d), std::cos(theta_d)};
  // Undo the reader's two rotations: by +θ_h about the binormal (y), then by +φ_h about the normal (z).
  const Vec3 r{d.x * ch + d.z * sh, d.y, -d.x * sh + d.z * ch};
  const Vec3 wi = normalize(Vec3{r.x * cp - r.y * sp, r.x * sp + r.y * cp, r.z});
  const Vec3 wo = normalize(h * (2.0 * dot(wi, h)) - wi);
  return {wo, wi};
}

MerlCoordinates merl_coordinates(const Vec3& wo, const Vec3& wi) {
  MerlCoordinates c;
  const Vec3 h = normalize(wi + wo);
  c.theta_h = std::acos(clamp1(h.z));
  const double phi_h = std::atan2(h.y, h.x);
  const double sp = std::sin(phi_h), cp = std::cos(phi_h);
  const double st = std::sin(c.theta_h), ct = std::cos(c.theta_h);
  const Vec3 t{wi.x * cp + wi.y * sp, -wi.x * sp + wi.y * cp, wi.z};  // rotate by −φ_h about z
  const Vec3 d{t.x * ct - t.z * st, t.y, t.x * st + t.z * ct};        // rotate by −θ_h about y
  c.theta_d = std::acos(clamp1(d.z));
  c.phi_d = std::atan2(d.y, d.x);
  if (c.phi_d < 0) c.phi_d += kPi;  // reciprocity: φ_d and φ_d + π are the same configuration with wi, wo swapped
  c.index_h = c.theta_h <= 0 ? 0.0 : std::sqrt(c.theta_h / kPiOver2) * kMerlThetaH;
  c.index_d = c.theta_d / kPiOver2 * kMerlThetaD;
  c.index_p = c.phi_d / kPi * kMerlPhiD;
  return c;
}

namespace {

// The values of one model at MERL configurations given by continuous indices (ih, id, ip).
class MerlSampler {
 public:
  MerlSampler(const brdf::Bxdf& bxdf, const MerlOptions& options)
      : bxdf_(bxdf),
        symmetrize_(options.symmetrize_if_not_reciprocal && !bxdf.reciprocal()),
        n_phi_h_(options.phi_h_samples) {}

  // f at one configuration, averaged over the azimuths of h; nullopt below the horizon.
  std::optional<Rgb> at(double xh, double xd, double xp) const {
    const double th = theta_h_at(xh), td = theta_d_at(xd), pd = phi_d_at(xp);
    Rgb sum;
    for (int m = 0; m < n_phi_h_; ++m) {
      const MerlDirections w = merl_directions(th, td, pd, 2.0 * kPi * m / n_phi_h_);
      // Rotating about the normal keeps the heights, so one azimuth decides for all.
      if (!brdf::valid_reflection_pair(w.wo, w.wi)) return std::nullopt;
      Rgb f = bxdf_.eval(w.wo, w.wi);
      if (symmetrize_) f = (f + bxdf_.eval(w.wi, w.wo)) * 0.5;
      sum += f;
    }
    return sum / n_phi_h_;
  }

  // The value of cell (ih, id, ip): f at its centre, or for a cell whose centre is below the horizon, what
  // straddling() finds.
  Rgb cell(int ih, int id, int ip) const {
    if (const std::optional<Rgb> centre = at(ih + 0.5, id + 0.5, ip + 0.5)) return *centre;
    // From a cell's centre to its corners wi turns by at most ½(π/90 + π/180 + π/180) ≈ 0.035 rad and wo by at most
    // ≈ 0.052 rad (θ_h counts twice for the mirrored direction), so their heights change by less than 0.06: a
    // centre further below the horizon than 0.1 is a cell wholly below, with no need to look at its corners.
    constexpr double kWhollyBelow = -0.1;
    const MerlDirections w = merl_directions(theta_h_at(ih + 0.5), theta_d_at(id + 0.5), phi_d_at(ip + 0.5));
    return std::fmin(w.wo.z, w.wi.z) > kWhollyBelow ? straddling(ih, id, ip) : Rgb{};
  }

 private:
  // A cell whose centre is below the horizon may still reach above it; a reader's lookup there must not find 0.
  // Such a cell holds the mean of f over its part above the horizon, sampled on a 4×4×4 grid in the cell; a sliver
  // the grid misses gets the mean over its corners above the horizon. The cell is found by its corners: if a point
  // of the cell is above the horizon, so is a corner (exactly so for a plane; the horizon is smooth on the scale of
  // a cell). No corner above: 0.
  Rgb straddling(int ih, int id, int ip) const {
    Rgb corner_sum;
    int corners = 0;
    for (int corner = 0; corner < 8; ++corner) {
      if (auto f = at(ih + (corner & 1), id + ((corner >> 1) & 1), ip + ((corner >> 2) & 1))) {
        corner_sum += *f;
        ++corners;
      }
    }
    if (corners == 0) return Rgb{};
    constexpr int kSub = 4;
    Rgb sum;
    int n = 0;
    for (int a = 0; a < kSub; ++a)
      for (int b = 0; b < kSub; ++b)
        for (int c = 0; c < kSub; ++c) {
          if (auto f = at(ih + (a + 0.5) / kSub, id + (b + 0.5) / kSub, ip + (c + 0.5) / kSub)) {
            sum += *f;
            ++n;
          }
        }
    return n > 0 ? sum / n : corner_sum / corners;
  }

  const brdf::Bxdf& bxdf_;
  bool symmetrize_;
  int n_phi_h_;
};

}  // namespace

MerlTable tabulate_merl(const brdf::Bxdf& bxdf, const MerlOptions& options) {
  if (options.phi_h_samples < 1 || options.phi_h_samples > 1024) {
    throw std::invalid_argument("tabulate_merl: phi_h_samples must be in [1, 1024], got " +
                                std::to_string(options.phi_h_samples));
  }
  const MerlSampler sampler(bxdf, options);
  MerlTable table;
  table.f.resize(kMerlEntries);
  tbb::parallel_for(tbb::blocked_range<int>(0, kMerlThetaH, 1), [&](const tbb::blocked_range<int>& rows) {
    for (int ih = rows.begin(); ih != rows.end(); ++ih) {
      for (int id = 0; id < kMerlThetaD; ++id) {
        for (int ip = 0; ip < kMerlPhiD; ++ip) table.f[MerlTable::merl_index(ih, id, ip)] = sampler.cell(ih, id, ip);
      }
      if (options.row_done) options.row_done();
    }
  });
  return table;
}

std::string encode_merl(const MerlTable& table) {
  if (table.f.size() != kMerlEntries) {
    throw std::invalid_argument("encode_merl: the table holds " + std::to_string(table.f.size()) +
                                " entries, the MERL layout needs " + std::to_string(kMerlEntries));
  }
  std::string out;
  out.reserve(kMerlFileBytes);
  for (int32_t dim : {kMerlThetaH, kMerlThetaD, kMerlPhiD}) append_le<int32_t>(out, dim);
  for (int c = 0; c < 3; ++c) {
    for (const Rgb& f : table.f) append_le<double>(out, f[c] / kMerlScale[c]);
  }
  return out;
}

std::string encode_merl(const brdf::Bxdf& bxdf, const MerlOptions& options) {
  return encode_merl(tabulate_merl(bxdf, options));
}

MerlTable decode_merl(const std::string& bytes) {
  if (bytes.size() < 12) {
    throw std::runtime_error("decode_merl: the data is " + std::to_string(bytes.size()) +
                             " bytes long, too short for the 12-byte header of a MERL BRDF file (three int32 "
                             "dimensions); the file is truncated or not a MERL file");
  }
  const int32_t dims[3] = {read_le<int32_t>(bytes.data()), read_le<int32_t>(bytes.data() + 4),
                           read_le<int32_t>(bytes.data() + 8)};
  if (dims[0] != kMerlThetaH || dims[1] != kMerlThetaD || dims[2] != kMerlPhiD) {
    throw std::runtime_error("decode_merl: the header gives dimensions " + std::to_string(dims[0]) + " x " +
                             std::to_string(dims[1]) + " x " + std::to_string(dims[2]) +
                             ", the MERL layout is 90 x 90 x 180 (theta_h, theta_d, phi_d); this is not a MERL "
                             "BRDF file or it uses another resolution");
  }
  if (bytes.size() != kMerlFileBytes) {
    throw std::runtime_error("decode_merl: the file is " + std::to_string(bytes.size()) + " bytes, a MERL file with " +
                             "90 x 90 x 180 entries is exactly " + std::to_string(kMerlFileBytes) + " bytes (" +
                             (bytes.size() < kMerlFileBytes ? "truncated" : "extra data after the table") + ")");
  }
  MerlTable table;
  table.f.resize(kMerlEntries);
  const char* p = bytes.data() + 12;
  for (int c = 0; c < 3; ++c) {
    for (size_t k = 0; k < kMerlEntries; ++k, p += 8) {
      const double v = read_le<double>(p);
      if (!std::isfinite(v)) {
        const int ip = static_cast<int>(k % kMerlPhiD), id = static_cast<int>(k / kMerlPhiD % kMerlThetaD),
                  ih = static_cast<int>(k / (size_t{kMerlPhiD} * kMerlThetaD));
        throw std::runtime_error("decode_merl: entry " + std::to_string(k) + " of channel " + kChannelNames[c] +
                                 " (theta_h index " + std::to_string(ih) + ", theta_d index " + std::to_string(id) +
                                 ", phi_d index " + std::to_string(ip) + ") is " + std::to_string(v) +
                                 "; a BRDF table must hold finite numbers");
      }
      const double f = v * kMerlScale[c];
      Rgb& e = table.f[k];
      (c == 0 ? e.r : c == 1 ? e.g : e.b) = f;
    }
  }
  return table;
}

Rgb lookup(const MerlTable& table, const Vec3& wo, const Vec3& wi) {
  if (!brdf::valid_reflection_pair(wo, wi) || table.f.size() != kMerlEntries) return Rgb{};
  const MerlCoordinates c = merl_coordinates(wo, wi);
  const Rgb& f = table.at(truncate_index(c.index_h, kMerlThetaH), truncate_index(c.index_d, kMerlThetaD),
                          truncate_index(c.index_p, kMerlPhiD));
  return {std::fmax(0.0, f.r), std::fmax(0.0, f.g), std::fmax(0.0, f.b)};
}

}  // namespace kiln::material
