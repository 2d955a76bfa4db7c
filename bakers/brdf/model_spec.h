// A plain description of one BRDF model and its parameters: what a job, the CLI or a test asks for.
// make_bxdf() builds the model; validate() names the first offending field in words for people.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "bakers/bake/invalid_input.h"
#include "bakers/math/rgb.h"

namespace kiln::brdf {

class Bxdf;

enum class Model {
  lambert,
  oren_nayar,         // full first-order Oren–Nayar (C1, C2, C3), optional two-bounce interreflection term
  oren_nayar_simple,  // the A/B approximation (survey eq 27)
  cook_torrance,      // Beckmann D, V-groove G, exact Fresnel from eta; normalisation 4 or pi
  ggx,                // Walter et al. 2007: GGX D, Smith G
  beckmann,           // Walter et al. 2007: Beckmann D, Smith G
  schlick,            // Schlick 1994 single layer (r, p)
  schlick_double,     // Schlick 1994 double layer
};

enum class FresnelMode { none, schlick, exact };
// Which normal distribution D the microfacet models use.
enum class Distribution { ggx, beckmann, schlick_beckmann /* Schlick's rational approximation of Beckmann (eq 20) */ };
// Which shadowing-masking G the microfacet models use.
enum class Masking {
  separable,          // Smith G1(i) G1(o), G1 derived from D
  height_correlated,  // Smith 1 / (1 + Λ(i) + Λ(o))
  v_groove,           // Cook–Torrance / Torrance–Sparrow V-cavities (survey eq 12)
  schlick,            // Schlick's rational G1(v) = v / (v − k v + k), k = α sqrt(2/π) (eq 19), separable
};
// Microfacet denominator: 4 (n·i)(n·o) as derived from the half-vector Jacobian, or π (n·i)(n·o) as printed in the
// survey's eq 9 (4/π too bright with a normalised D; kept to measure it).
enum class Normalization { four, pi };

// One layer of Schlick's model.
struct SchlickLayer {
  Rgb c{0.8};      // reflection factor C_λ at normal incidence (Schlick's S(u) uses it as f0)
  double r = 0.5;  // roughness: 0 perfect mirror, 1 Lambertian (at p = 1; the azimuthal factor A stays for p < 1)
  double p = 1.0;  // isotropy: 1 isotropic, towards 0 anisotropic along the tangent
};

struct ModelSpec {
  Model model = Model::lambert;

  Rgb albedo{0.8};               // diffuse reflectance ρ (lambert, oren-nayar)
  double sigma = 0.0;            // Oren–Nayar roughness, standard deviation of facet slope angle, radians
  bool interreflection = false;  // Oren–Nayar two-bounce term (oren_nayar only)

  double alpha_x = 0.3, alpha_y = 0.3;  // width of D as it appears in the formula (GGX α, Beckmann m)
  // Unset: the model's own Fresnel term, exact for cook-torrance, none (F = 1, the white furnace) for the others.
  std::optional<FresnelMode> fresnel;
  Rgb f0{0.04};      // reflectance at normal incidence for Schlick's Fresnel
  double eta = 1.5;  // relative index of refraction n_t / n_i for the exact Fresnel (dielectric)
  std::optional<Distribution> distribution;  // override the model's own D
  std::optional<Masking> masking;            // override the model's own G
  Normalization normalization = Normalization::four;

  SchlickLayer layer;         // schlick, and the top layer of schlick_double
  SchlickLayer bottom_layer;  // schlick_double: the layer under the top one
};

// The Fresnel term the model will use: spec.fresnel, or the model's own default.
FresnelMode fresnel_mode(const ModelSpec& spec);

// nullopt if the spec is valid; otherwise the first offending field ("alpha_x") and what is wrong with it.
std::optional<bake::InvalidInput> validate(const ModelSpec& spec);

// Builds the model; throws validate()'s bake::InvalidInput if the spec is invalid.
std::unique_ptr<Bxdf> make_bxdf(const ModelSpec& spec);

// Names used by the CLI and job files: "lambert", "oren-nayar", ..., and back.
std::string to_string(Model m);
std::optional<Model> model_from_string(const std::string& name);
std::string to_string(FresnelMode m);
std::string to_string(Distribution d);
std::string to_string(Masking m);
std::string to_string(Normalization n);
std::optional<FresnelMode> fresnel_from_string(const std::string& name);
std::optional<Distribution> distribution_from_string(const std::string& name);
std::optional<Masking> masking_from_string(const std::string& name);
std::optional<Normalization> normalization_from_string(const std::string& name);
// Every accepted name of an enum, "a|b|c", for error messages and --help.
std::string model_names();
std::string fresnel_names();
std::string distribution_names();
std::string masking_names();
std::string normalization_names();

// The parameter that the tables call "roughness" for this model, and how to set it: α for the microfacet models
// (both α_x and α_y), r for Schlick's models, σ for Oren–Nayar (in radians); Lambert has none.
const char* roughness_name(Model m);
ModelSpec with_roughness(ModelSpec spec, double roughness);

}  // namespace kiln::brdf
