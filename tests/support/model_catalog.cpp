#include "tests/support/model_catalog.h"

#include <cstdio>
#include <stdexcept>
#include <tuple>

#include "bakers/math/constants.h"

namespace kiln::test {

using brdf::Distribution;
using brdf::FresnelMode;
using brdf::Masking;
using brdf::Model;
using brdf::ModelSpec;
using brdf::Normalization;

std::unique_ptr<brdf::Bxdf> CatalogEntry::make() const { return brdf::make_bxdf(spec); }

namespace {

// "0.05" -> "0_05": parameter values inside GoogleTest names.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.15g", v);
  std::string s(buf);
  for (char& c : s)
    if (c == '.' || c == '-' || c == '+') c = '_';
  return s;
}

const char* name_of(Masking m) {
  switch (m) {
    case Masking::separable:
      return "sep";
    case Masking::height_correlated:
      return "hc";
    case Masking::v_groove:
      return "vgroove";
    case Masking::schlick:
      return "schlickG";
  }
  return "?";
}

const char* name_of(FresnelMode f) {
  switch (f) {
    case FresnelMode::none:
      return "Fnone";
    case FresnelMode::schlick:
      return "Fschlick";
    case FresnelMode::exact:
      return "Fexact";
  }
  return "?";
}

ModelSpec microfacet(Model model, double ax, double ay, Masking masking, FresnelMode fresnel) {
  ModelSpec s;
  s.model = model;
  s.alpha_x = ax;
  s.alpha_y = ay;
  s.masking = masking;
  s.fresnel = fresnel;
  s.f0 = Rgb(0.9, 0.6, 0.05);  // a coloured f0 so that channel mix-ups show
  s.eta = 1.5;
  return s;
}

CatalogEntry entry(std::string name, ModelSpec spec) {
  CatalogEntry e;
  e.name = std::move(name);
  e.spec = spec;
  return e;
}

void add_microfacet_family(std::vector<CatalogEntry>& out, Model model, const char* prefix) {
  struct Width {
    double ax, ay;
  };
  const Width widths[] = {{0.05, 0.05}, {0.3, 0.3}, {1.0, 1.0}, {0.1, 0.5}};
  // Every width with the two masking forms, each paired with a Fresnel mode; every remaining masking × Fresnel
  // combination at α = 0.3 (a pairwise design: each option meets every width and every other option).
  for (const Width& w : widths) {
    const bool aniso = w.ax != w.ay;
    const std::string wname = aniso ? "a" + num(w.ax) + "x" + num(w.ay) : "a" + num(w.ax);
    for (auto [m, f] : {std::pair{Masking::separable, FresnelMode::none},
                        std::pair{Masking::height_correlated, FresnelMode::exact}}) {
      CatalogEntry e = entry(std::string(prefix) + "_" + wname + "_" + name_of(m) + "_" + name_of(f),
                             microfacet(model, w.ax, w.ay, m, f));
      e.anisotropic = aniso;
      e.sharp = std::min(w.ax, w.ay) <= 0.1;
      e.sampling_variant = m == Masking::height_correlated;
      out.push_back(e);
    }
  }
  for (auto [m, f] :
       {std::pair{Masking::separable, FresnelMode::schlick}, std::pair{Masking::separable, FresnelMode::exact},
        std::pair{Masking::height_correlated, FresnelMode::none},
        std::pair{Masking::height_correlated, FresnelMode::schlick}}) {
    CatalogEntry e =
        entry(std::string(prefix) + "_a0_3_" + name_of(m) + "_" + name_of(f), microfacet(model, 0.3, 0.3, m, f));
    e.sampling_variant = true;
    out.push_back(e);
  }
  // Total internal reflection for eta < 1 in the exact Fresnel.
  ModelSpec tir = microfacet(model, 0.3, 0.3, Masking::height_correlated, FresnelMode::exact);
  tir.eta = 0.7;
  CatalogEntry e = entry(std::string(prefix) + "_a0_3_hc_Fexact_eta0_7", tir);
  e.sampling_variant = true;
  out.push_back(e);
}

std::vector<CatalogEntry> build_catalog() {
  std::vector<CatalogEntry> out;

  {
    ModelSpec s;
    s.model = Model::lambert;
    s.albedo = Rgb(0.8);
    out.push_back(entry("lambert", s));
    s.albedo = Rgb(0.9, 0.5, 0.1);
    out.push_back(entry("lambert_coloured", s));
  }

  for (double sigma : {0.0, 0.3, 1.0}) {
    for (bool ir : {false, true}) {
      ModelSpec s;
      s.model = Model::oren_nayar;
      s.albedo = Rgb(0.9, 0.5, 0.1);
      s.sigma = sigma;
      s.interreflection = ir;
      CatalogEntry e = entry("oren_nayar_s" + num(sigma) + (ir ? "_ir" : ""), s);
      // The first-order model stays below 1 at σ = 0.3 and 1 (it exceeds 1 by up to 0.4% at grazing angles only for
      // σ ≈ 0.1–0.2); the two-bounce term adds up to ~5% at grazing angles for ρ = 1 (σ ≈ 0.3). σ = 0 is Lambert.
      e.energy_conserving = !ir || sigma == 0.0;
      e.sampling_variant = ir;
      out.push_back(e);
    }
  }
  for (double sigma : {0.0, 0.2, 0.3, 1.0}) {
    ModelSpec s;
    s.model = Model::oren_nayar_simple;
    s.albedo = Rgb(0.9, 0.5, 0.1);
    s.sigma = sigma;
    CatalogEntry e = entry("oren_nayar_simple_s" + num(sigma), s);
    // σ = 0 is exactly Lambert (B = 0, A = 1); any σ > 0 has the grazing excess (largest near σ = 0.2).
    e.energy_conserving = sigma == 0.0;
    out.push_back(e);
  }

  for (double alpha : {0.1, 0.3}) {
    for (Normalization n : {Normalization::four, Normalization::pi}) {
      for (double eta : {1.5, 0.7}) {
        if (alpha == 0.1 && eta != 1.5) continue;
        ModelSpec s;
        s.model = Model::cook_torrance;
        s.alpha_x = s.alpha_y = alpha;
        s.fresnel = FresnelMode::exact;
        s.eta = eta;
        s.normalization = n;
        CatalogEntry e = entry(
            "cook_torrance_a" + num(alpha) + (n == Normalization::pi ? "_normpi" : "_norm4") + "_eta" + num(eta), s);
        e.energy_conserving = n == Normalization::four;
        e.sharp = alpha <= 0.1;
        e.sampling_variant = n == Normalization::pi || eta != 1.5;
        out.push_back(e);
      }
    }
  }

  add_microfacet_family(out, Model::ggx, "ggx");
  add_microfacet_family(out, Model::beckmann, "beckmann");

  // Overrides of D and G.
  for (double alpha : {0.1, 0.5}) {
    ModelSpec s = microfacet(Model::beckmann, alpha, alpha, Masking::separable, FresnelMode::none);
    s.distribution = Distribution::schlick_beckmann;
    CatalogEntry e = entry("beckmann_schlickD_a" + num(alpha), s);
    e.sharp = alpha <= 0.1;
    // Schlick's rational D with the Beckmann Smith Λ under-masks at grazing angles: E > 1 there (energy_test.cpp).
    e.energy_conserving = false;
    out.push_back(e);
  }
  {
    ModelSpec s = microfacet(Model::ggx, 0.3, 0.3, Masking::height_correlated, FresnelMode::schlick);
    s.distribution = Distribution::schlick_beckmann;
    CatalogEntry e = entry("ggx_schlickD_a0_3_hc_Fschlick", s);
    e.energy_conserving = false;
    out.push_back(e);
  }
  for (Model m : {Model::ggx, Model::beckmann}) {
    const char* p = m == Model::ggx ? "ggx" : "beckmann";
    for (auto [g, f, suffix] : {std::tuple{Masking::v_groove, FresnelMode::none, "_a0_3_vgroove"},
                                std::tuple{Masking::schlick, FresnelMode::schlick, "_a0_3_schlickG"}}) {
      CatalogEntry e = entry(std::string(p) + suffix, microfacet(m, 0.3, 0.3, g, f));
      e.sampling_variant = true;
      out.push_back(e);
    }
  }
  {
    CatalogEntry e =
        entry("ggx_a0_1x0_5_vgroove", microfacet(Model::ggx, 0.1, 0.5, Masking::v_groove, FresnelMode::none));
    e.anisotropic = true;
    e.sharp = true;
    e.sampling_variant = true;
    out.push_back(e);
  }

  // Schlick's single-layer model.
  for (double r : {0.1, 0.5, 1.0}) {
    for (double p : {0.3, 1.0}) {
      ModelSpec s;
      s.model = Model::schlick;
      s.layer.c = Rgb(0.9, 0.5, 0.1);
      s.layer.r = r;
      s.layer.p = p;
      CatalogEntry e = entry("schlick_r" + num(r) + "_p" + num(p), s);
      e.anisotropic = p != 1.0;
      // Schlick's Z(t) = r / (1 + r t² − t²)² is GGX's D with α² = r: r = 0.1 is as wide as α ≈ 0.32, not sharp.
      e.sharp = r <= 0.01;
      out.push_back(e);
    }
  }
  // The double layer: a glossy top over a rough bottom, isotropic and anisotropic.
  for (double p : {1.0, 0.3}) {
    ModelSpec s;
    s.model = Model::schlick_double;
    s.layer.c = Rgb(0.04);
    s.layer.r = 0.1;
    s.layer.p = p;
    s.bottom_layer.c = Rgb(0.9, 0.5, 0.1);
    s.bottom_layer.r = 0.8;
    s.bottom_layer.p = 1.0;
    CatalogEntry e = entry("schlick_double_p" + num(p), s);
    e.anisotropic = p != 1.0;
    e.sharp = false;  // top layer r = 0.1: α ≈ 0.32 (see above)
    out.push_back(e);
  }
  return out;
}

std::vector<CatalogEntry> build_extremes() {
  std::vector<CatalogEntry> out;
  for (Model m : {Model::ggx, Model::beckmann}) {
    const std::string p = m == Model::ggx ? "ggx" : "beckmann";
    out.push_back(entry(p + "_a1e_06", microfacet(m, 1e-6, 1e-6, Masking::height_correlated, FresnelMode::exact)));
    out.push_back(entry(p + "_a1e_06_sep", microfacet(m, 1e-6, 1e-6, Masking::separable, FresnelMode::schlick)));
    out.push_back(entry(p + "_a1e_06x1", microfacet(m, 1e-6, 1.0, Masking::separable, FresnelMode::none)));
    out.push_back(entry(p + "_a1_hc", microfacet(m, 1.0, 1.0, Masking::height_correlated, FresnelMode::none)));
    out.push_back(entry(p + "_a1e_06_vgroove", microfacet(m, 1e-6, 1e-6, Masking::v_groove, FresnelMode::none)));
    out.push_back(entry(p + "_a1e_06_schlickG", microfacet(m, 1e-6, 1e-6, Masking::schlick, FresnelMode::none)));
    out.push_back(entry(p + "_a1_schlickG", microfacet(m, 1.0, 1.0, Masking::schlick, FresnelMode::none)));
    for (double eta : {1.0, 1.0 + 1e-12, 1.0 - 1e-12, 0.5, 0.1, 10.0}) {
      ModelSpec s = microfacet(m, 0.3, 0.3, Masking::separable, FresnelMode::exact);
      s.eta = eta;
      out.push_back(entry(p + "_eta" + num(eta), s));
    }
    for (double f0 : {0.0, 1.0}) {
      ModelSpec s = microfacet(m, 0.3, 0.3, Masking::separable, FresnelMode::schlick);
      s.f0 = Rgb(f0);
      out.push_back(entry(p + "_f0_" + num(f0), s));
    }
  }
  {
    ModelSpec s = microfacet(Model::beckmann, 1e-6, 1e-6, Masking::separable, FresnelMode::none);
    s.distribution = Distribution::schlick_beckmann;
    out.push_back(entry("beckmann_schlickD_a1e_06", s));
    s.alpha_x = s.alpha_y = 1.0;
    out.push_back(entry("beckmann_schlickD_a1", s));
  }
  for (double alpha : {1e-6, 1.0}) {
    for (double eta : {1.0, 0.5, 10.0}) {
      ModelSpec s;
      s.model = Model::cook_torrance;
      s.alpha_x = s.alpha_y = alpha;
      s.fresnel = FresnelMode::exact;
      s.eta = eta;
      for (Normalization n : {Normalization::four, Normalization::pi}) {
        s.normalization = n;
        out.push_back(entry(
            "cook_torrance_a" + num(alpha) + "_eta" + num(eta) + (n == Normalization::pi ? "_normpi" : "_norm4"), s));
      }
    }
  }
  for (double sigma : {0.0, 1e-8, 1.0, 1.5, kPiOver2}) {
    for (Model m : {Model::oren_nayar, Model::oren_nayar_simple}) {
      ModelSpec s;
      s.model = m;
      s.albedo = Rgb(1.0);
      s.sigma = sigma;
      out.push_back(
          entry(std::string(m == Model::oren_nayar ? "oren_nayar" : "oren_nayar_simple") + "_s" + num(sigma), s));
      if (m == Model::oren_nayar) {
        s.interreflection = true;
        out.push_back(entry("oren_nayar_ir_s" + num(sigma), s));
      }
    }
  }
  {
    ModelSpec s;
    s.model = Model::lambert;
    s.albedo = Rgb(0.0);
    out.push_back(entry("lambert_black", s));
    s.albedo = Rgb(1.0);
    out.push_back(entry("lambert_white", s));
  }
  for (double r : {0.0, 1e-6, 1.0}) {
    for (double p : {0.0, 1e-6, 1.0}) {
      for (double c : {0.0, 1.0}) {
        ModelSpec s;
        s.model = Model::schlick;
        s.layer.c = Rgb(c);
        s.layer.r = r;
        s.layer.p = p;
        out.push_back(entry("schlick_r" + num(r) + "_p" + num(p) + "_c" + num(c), s));
      }
    }
  }
  for (double r : {0.0, 1.0}) {
    for (double p : {0.0, 1.0}) {
      ModelSpec s;
      s.model = Model::schlick_double;
      s.layer.c = Rgb(1.0);
      s.layer.r = r;
      s.layer.p = p;
      s.bottom_layer.c = Rgb(1.0);
      s.bottom_layer.r = 1.0 - r;
      s.bottom_layer.p = 1.0 - p;
      out.push_back(entry("schlick_double_r" + num(r) + "_p" + num(p), s));
    }
  }
  for (CatalogEntry& e : out) {
    e.name = "extreme_" + e.name;
    // These are run for stability only; the flags are not used.
    e.energy_conserving = false;
    e.sharp = true;
  }
  return out;
}

}  // namespace

const std::vector<CatalogEntry>& model_catalog() {
  static const std::vector<CatalogEntry> catalog = build_catalog();
  return catalog;
}

const std::vector<CatalogEntry>& extreme_catalog() {
  static const std::vector<CatalogEntry> catalog = build_extremes();
  return catalog;
}

const CatalogEntry& catalog_entry(const std::string& name) {
  for (const auto* list : {&model_catalog(), &extreme_catalog()})
    for (const CatalogEntry& e : *list)
      if (e.name == name) return e;
  throw std::out_of_range("no catalogue entry named " + name);
}

void PrintTo(const CatalogEntry& e, std::ostream* os) { *os << e.name; }
void PrintTo(const CatalogEntry* e, std::ostream* os) { *os << (e ? e->name : "null"); }

}  // namespace kiln::test
