#include "bakers/material/table_entry.h"

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/math/vec3.h"

namespace kiln::material {
namespace {

Vec3 direction_from(double mu, double phi) {
  const double s = std::sqrt(std::fmax(0.0, 1.0 - mu * mu));
  return {s * std::cos(phi), s * std::sin(phi), mu};
}

Rgb sqrt_rgb(const Rgb& c) { return {std::sqrt(c.r), std::sqrt(c.g), std::sqrt(c.b)}; }

// The estimator of brdf/albedo.cpp (independent replicates of n×n jittered strata; their spread gives the standard
// error), for the integrals that library offers only as whole tables: one split-sum entry, the average albedo.
// One stratified estimate of `samples` samples: the albedo library's estimator, so both count and combine alike.
brdf::Estimate stratified(uint64_t samples, uint64_t seed, uint64_t stream,
                          const brdf::SampleContribution& contribution) {
  brdf::AlbedoOptions o;
  o.samples = static_cast<int>(samples);
  o.replicates = kReplicates;
  o.seed = seed;
  return brdf::stratified_estimate(o, stream, contribution);
}

// E_avg = 2 ∫ E(μ) μ dμ, estimated directly: μ = √ξ has density 2μ.
brdf::Estimate average_albedo_block(const brdf::Bxdf& b, uint64_t samples, uint64_t seed) {
  return stratified(samples, seed, 3, [&](Point2 u, double uc, Pcg32& rng) {
    const double mu = std::sqrt(1.0 - rng.uniform());  // density 2μ on (0, 1]
    const auto s = b.sample(direction_from(mu, 2.0 * kPi * rng.uniform()), u, uc);
    return s ? s->weight : Rgb{};
  });
}

// As brdf::split_sum_table: Schlick's weight c = (1 − wo·wh)^5 splits the white albedo into scale and bias.
brdf::Estimate split_sum_block(const brdf::Bxdf& b, double mu, uint64_t samples, uint64_t seed) {
  return stratified(samples, seed, 4, [&](Point2 u, double uc, Pcg32& rng) {
    const Vec3 wo = direction_from(mu, 2.0 * kPi * rng.uniform());
    const auto s = b.sample(wo, u, uc);
    if (!s) return Rgb{};
    const double c = std::pow(1.0 - std::fmax(0.0, dot(wo, normalize(wo + s->wi))), 5.0);
    const double w = s->weight.average();
    return Rgb{w * (1.0 - c), w * c, 0.0};
  });
}

}  // namespace

Rgb Entry::mean() const { return samples ? weighted_sum / static_cast<double>(samples) : Rgb{}; }

Rgb Entry::std_error() const { return samples ? sqrt_rgb(weighted_variance) / static_cast<double>(samples) : Rgb{}; }

double Entry::error() const {
  const Rgb se = std_error();
  return kind == Kind::split_sum ? std::max(se.r, se.g) : se.max();
}

void Entry::add(const brdf::Estimate& e) {
  const double n = static_cast<double>(e.samples);
  weighted_sum += e.value * n;
  weighted_variance += e.std_error * e.std_error * (n * n);
  samples += static_cast<uint64_t>(e.samples);
}

brdf::Estimate Entry::estimate() const {
  brdf::Estimate est;
  est.value = mean();
  est.std_error = std_error();
  est.samples = static_cast<int64_t>(samples);
  return est;
}

uint64_t splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

uint64_t block_seed(uint64_t seed, uint64_t entry, uint64_t block) {
  return splitmix64(splitmix64(seed) ^ splitmix64((entry << 24) + block));
}

uint64_t taken(uint64_t requested) {
  brdf::AlbedoOptions o;
  o.samples = static_cast<int>(requested);
  o.replicates = kReplicates;
  return static_cast<uint64_t>(brdf::stratified_sample_count(o));
}

uint64_t taken_in_blocks(uint64_t requested) {
  uint64_t total = 0;
  for (; requested > kMaxBlock; requested -= kMaxBlock) total += taken(kMaxBlock);
  return total + (requested ? taken(requested) : 0);
}

brdf::Estimate estimate_block(const TableModels& models, const Entry& e, int n_mu, uint64_t samples, uint64_t seed) {
  brdf::AlbedoOptions o;
  o.samples = static_cast<int>(samples);
  o.replicates = kReplicates;
  o.seed = seed;
  switch (e.kind) {
    case Kind::albedo:
      return brdf::directional_albedo(*models.bxdf, mu_at(e.i_mu, n_mu), o);
    case Kind::white:
      return brdf::directional_albedo(*models.white, mu_at(e.i_mu, n_mu), o);
    case Kind::average:
      return average_albedo_block(*models.bxdf, samples, seed);
    case Kind::white_average:
      return average_albedo_block(*models.white, samples, seed);
    case Kind::split_sum:
      return split_sum_block(*models.rows[e.i_roughness], mu_at(e.i_mu, n_mu), samples, seed);
  }
  return brdf::Estimate{};
}

}  // namespace kiln::material
