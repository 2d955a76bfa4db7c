#include "bakers/volume/phase_mixture.h"

namespace kiln::volume {

void PhaseMixture::add(double g, const Rgb& sigma_s) {
  if (!(sigma_s.max() > 0) || n_ == kMaxLobes) return;
  g_[n_] = g;
  weight_[n_] = sigma_s;
  ++n_;
}

bool PhaseMixture::finish() {
  Rgb total;
  for (int i = 0; i < n_; ++i) total += weight_[i];
  auto over = [](double w, double t) { return t > 0 ? w / t : 0.0; };
  double q_total = 0;
  for (int i = 0; i < n_; ++i) {
    weight_[i] = {over(weight_[i].r, total.r), over(weight_[i].g, total.g), over(weight_[i].b, total.b)};
    q_[i] = weight_[i].max();
    q_total += q_[i];
  }
  if (!(q_total > 0)) return false;
  for (int i = 0; i < n_; ++i) q_[i] /= q_total;
  return true;
}

Rgb PhaseMixture::p(const Vec3& wo, const Vec3& wi) const {
  Rgb value;
  for (int i = 0; i < n_; ++i) value += weight_[i] * lobe(i).p(wo, wi);
  return value;
}

double PhaseMixture::pdf(const Vec3& wo, const Vec3& wi) const {
  double pdf = 0;
  for (int i = 0; i < n_; ++i) pdf += q_[i] * lobe(i).pdf(wo, wi);
  return pdf;
}

PhaseMixture::Sample PhaseMixture::sample(const Vec3& wo, double u0, Point2 u) const {
  int i = 0;
  for (double c = q_[0]; i + 1 < n_ && u0 >= c; c += q_[++i]) {
  }
  if (n_ == 1) {
    // One lobe: p/pdf is its weight exactly (1 in every channel that scatters), with no cancellation.
    const HenyeyGreenstein::Sample h = lobe(0).sample(wo, u);
    return {h.wi, weight_[0], h.pdf};
  }
  Sample s;
  s.wi = lobe(i).sample(wo, u).wi;
  s.pdf = pdf(wo, s.wi);
  s.weight = s.pdf > 0 ? p(wo, s.wi) / s.pdf : Rgb{};
  return s;
}

}  // namespace kiln::volume
