// kiln-brdf: the BRDF library for people and scripts.
//   kiln-brdf eval   --model M [params] --wo x,y,z --wi x,y,z   f(wo, wi) per channel (one value if grey)
//   kiln-brdf albedo --model M [params] --mu MU                 directional albedo E(μ) with its standard error
//   kiln-brdf table  --model M [params]                         albedo and split-sum tables as CSV
// --diffuse M --specular M [--combine ...] with --diffuse-PARAM and --specular-PARAM in place of --model M [params]
// takes a two-lobe material (brdf::Material, the model lightmaps shade with).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/bake/number_format.h"
#include "bakers/brdf/albedo.h"
#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/material.h"
#include "bakers/brdf/model_spec.h"

namespace {

using namespace kiln;
using namespace kiln::brdf;
using kiln::bake::format_number;

// A usage error: printed as one line, exit status 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

constexpr const char* kUsage = R"(usage: kiln-brdf eval|albedo|table --model MODEL [parameters] [options]
       kiln-brdf eval|albedo|table --diffuse MODEL --specular MODEL [material] [lobe parameters] [options]

commands:
  eval   --wo x,y,z --wi x,y,z   print f(wo, wi) without the cosine (one value per RGB channel, or one if grey);
                                 directions in the local frame, normal +z, both pointing away from the surface
  albedo --mu MU                 print the directional albedo E(MU) = integral of f cos(theta_i), MU = cos(theta_o)
                                 in (0, 1], then its standard error and the sample count
  table                          print the directional albedo table and the split-sum table (scale, bias on f0)
                                 as CSV

models: lambert, oren-nayar, oren-nayar-simple, cook-torrance, ggx, beckmann, schlick, schlick-double
parameters:
  --albedo A | R,G,B          diffuse reflectance (lambert, oren-nayar*), default 0.8
  --sigma S                   Oren-Nayar roughness in radians, [0, pi/2], default 0
  --interreflection on|off    Oren-Nayar two-bounce term (oren-nayar), default off
  --alpha A                   width of D as in the formula (GGX alpha, Beckmann m), (0, 1], default 0.3
  --alpha-x A --alpha-y A     anisotropic widths along the tangent and the bitangent
  --fresnel none|schlick|exact  Fresnel term; default exact for cook-torrance, none (the white furnace) otherwise
  --f0 F | R,G,B              reflectance at normal incidence for --fresnel schlick, default 0.04
  --eta ETA                   relative index of refraction n_t/n_i for --fresnel exact, [0.1, 10], default 1.5
  --distribution ggx|beckmann|schlick-beckmann   override the model's D
  --masking separable|height-correlated|v-groove|schlick   override the model's G
  --normalization 4|pi        microfacet denominator, default 4
  --c C | R,G,B  --r R  --p P            Schlick layer: reflection factor, roughness, isotropy (top layer)
  --bottom-c C --bottom-r R --bottom-p P  Schlick double layer: the bottom layer
two-lobe material (brdf::Material, what lightmaps shade with), instead of --model:
  --diffuse MODEL --specular MODEL   the lobes, each any model above (usually lambert or oren-nayar, and ggx)
  --combine layered|weights   layered (default): the diffuse lobe gets what the specular one does not reflect;
                              weights: d * diffuse + s * specular with d = 1 - s
  --specular-weight S         s for --combine weights, [0, 1], default 0.5
  --diffuse-PARAM V, --specular-PARAM V   a lobe's parameter, e.g. --diffuse-albedo 0.8 --specular-alpha 0.3
                              --specular-fresnel schlick --specular-f0 0.04
                              (table: the split-sum table is the specular lobe's)
options:
  --samples N                 samples per estimate (albedo, table), default 65536 for albedo, 4096 for table
  --n-mu N --n-roughness N    table resolution, default 32 x 32
  --seed N                    random seed, default 1
)";

double parse_number(const std::string& flag, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') throw UsageError(flag + ": expected a number, got '" + text + "'");
  return v;
}

std::vector<double> parse_list(const std::string& flag, const std::string& text) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(parse_number(flag, item));
  return out;
}

Rgb parse_rgb(const std::string& flag, const std::string& text) {
  const std::vector<double> v = parse_list(flag, text);
  if (v.size() == 1) return Rgb{v[0]};
  if (v.size() == 3) return Rgb{v[0], v[1], v[2]};
  throw UsageError(flag + ": expected one value or three (R,G,B), got '" + text + "'");
}

Vec3 parse_direction(const std::string& flag, const std::string& text) {
  const std::vector<double> v = parse_list(flag, text);
  if (v.size() != 3) throw UsageError(flag + ": expected x,y,z, got '" + text + "'");
  const Vec3 d{v[0], v[1], v[2]};
  if (!is_finite(d)) throw UsageError(flag + ": must be a finite non-zero vector, got '" + text + "'");
  // People type directions like 1,0,1; the library expects unit vectors. Scaling by the largest component first
  // keeps the length computable: squaring 1e308 overflows and squaring 1e-320 underflows to 0, while the scaled
  // vector has its largest component ±1 and a length in [1, √3].
  const double largest = std::fmax(std::fabs(d.x), std::fmax(std::fabs(d.y), std::fabs(d.z)));
  if (largest == 0.0) throw UsageError(flag + ": must be a finite non-zero vector, got '" + text + "'");
  const Vec3 scaled = d / largest;
  return scaled / length(scaled);
}

int parse_count(const std::string& flag, const std::string& text, int lo, int hi) {
  const double v = parse_number(flag, text);
  if (!(v >= lo && v <= hi) || v != std::floor(v)) {
    throw UsageError(flag + ": must be a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                     "], got '" + text + "'");
  }
  return static_cast<int>(v);
}

template <typename E>
E parse_enum(const std::string& flag, const std::string& text, std::optional<E> (*parse)(const std::string&),
             const std::string& names) {
  if (auto e = parse(text)) return *e;
  throw UsageError(flag + ": expected one of " + names + ", got '" + text + "'");
}

struct Command {
  std::string name;
  ModelSpec spec;                              // one model, or the specular lobe of `material`
  std::optional<MaterialSpec> material;        // a two-lobe material (--diffuse and --specular)
  std::map<std::string, std::string> options;  // command options (--wo, --mu, --samples, ...)
};

using Take = std::function<std::optional<std::string>(const std::string&)>;

// One model's parameters: --albedo, --alpha, ... for a single model; --diffuse-albedo, --specular-alpha, ... for a
// lobe of a two-lobe material (prefix "diffuse-" or "specular-"). The model itself comes from `model_flag`.
ModelSpec parse_model(const Take& take, const std::string& model_flag, const std::string& model_text,
                      const std::string& prefix) {
  const auto flag = [&](const char* name) { return "--" + prefix + name; };
  ModelSpec s;
  s.model = parse_enum<Model>(model_flag, model_text, model_from_string, model_names());
  const bool schlick_model = s.model == Model::schlick || s.model == Model::schlick_double;

  if (auto v = take(flag("albedo"))) {
    if (schlick_model) {
      s.layer.c = parse_rgb(flag("albedo"), *v);
    } else {
      s.albedo = parse_rgb(flag("albedo"), *v);
    }
  }
  if (auto v = take(flag("sigma"))) s.sigma = parse_number(flag("sigma"), *v);
  if (auto v = take(flag("interreflection"))) {
    if (*v != "on" && *v != "off") throw UsageError(flag("interreflection") + ": expected on or off, got '" + *v + "'");
    s.interreflection = *v == "on";
  }
  if (auto v = take(flag("alpha"))) s.alpha_x = s.alpha_y = parse_number(flag("alpha"), *v);
  if (auto v = take(flag("alpha-x"))) s.alpha_x = parse_number(flag("alpha-x"), *v);
  if (auto v = take(flag("alpha-y"))) s.alpha_y = parse_number(flag("alpha-y"), *v);
  if (auto v = take(flag("fresnel")))
    s.fresnel = parse_enum<FresnelMode>(flag("fresnel"), *v, fresnel_from_string, fresnel_names());
  if (auto v = take(flag("f0"))) s.f0 = parse_rgb(flag("f0"), *v);
  if (auto v = take(flag("eta"))) s.eta = parse_number(flag("eta"), *v);
  if (auto v = take(flag("distribution"))) {
    s.distribution = parse_enum<Distribution>(flag("distribution"), *v, distribution_from_string, distribution_names());
  }
  if (auto v = take(flag("masking")))
    s.masking = parse_enum<Masking>(flag("masking"), *v, masking_from_string, masking_names());
  if (auto v = take(flag("normalization"))) {
    s.normalization =
        parse_enum<Normalization>(flag("normalization"), *v, normalization_from_string, normalization_names());
  }
  if (auto v = take(flag("c"))) s.layer.c = parse_rgb(flag("c"), *v);
  if (auto v = take(flag("r"))) s.layer.r = parse_number(flag("r"), *v);
  if (auto v = take(flag("p"))) s.layer.p = parse_number(flag("p"), *v);
  if (auto v = take(flag("bottom-c"))) s.bottom_layer.c = parse_rgb(flag("bottom-c"), *v);
  if (auto v = take(flag("bottom-r"))) s.bottom_layer.r = parse_number(flag("bottom-r"), *v);
  if (auto v = take(flag("bottom-p"))) s.bottom_layer.p = parse_number(flag("bottom-p"), *v);
  if (auto error = validate(s)) {
    throw UsageError(prefix.empty() ? error->what() : error->under(prefix.substr(0, prefix.size() - 1)).what());
  }
  return s;
}

// --diffuse MODEL --specular MODEL [--combine layered|weights] [--specular-weight S] and the lobes' parameters.
MaterialSpec parse_material(const Take& take) {
  const auto diffuse = take("--diffuse");
  const auto specular = take("--specular");
  if (!diffuse || !specular) {
    throw UsageError(std::string(diffuse ? "--specular" : "--diffuse") +
                     ": missing; a two-lobe material needs both --diffuse MODEL and --specular MODEL");
  }
  MaterialSpec m;
  m.diffuse = parse_model(take, "--diffuse", *diffuse, "diffuse-");
  m.specular = parse_model(take, "--specular", *specular, "specular-");
  if (auto v = take("--combine")) {
    if (*v != "layered" && *v != "weights") {
      throw UsageError("--combine: expected layered or weights, got '" + *v + "'");
    }
    m.combine = *v == "weights" ? Combine::weights : Combine::layered;
  }
  if (auto v = take("--specular-weight")) {
    if (m.combine != Combine::weights) throw UsageError("--specular-weight: applies to --combine weights only");
    m.specular_weight = parse_number("--specular-weight", *v);
  }
  if (auto error = validate(m)) throw UsageError(error->what());
  return m;
}

Command parse_command(int argc, char** argv) {
  if (argc < 2) throw UsageError("missing command: expected eval, albedo or table (see --help)");
  Command cmd;
  cmd.name = argv[1];
  if (cmd.name != "eval" && cmd.name != "albedo" && cmd.name != "table") {
    throw UsageError("unknown command '" + cmd.name + "': expected eval, albedo or table (see --help)");
  }
  std::map<std::string, std::string> args;
  for (int i = 2; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + flag + "' (see --help)");
    if (i + 1 >= argc) throw UsageError(flag + ": missing value");
    if (args.count(flag)) throw UsageError(flag + ": given twice");
    args[flag] = argv[++i];
  }
  const Take take = [&](const std::string& flag) -> std::optional<std::string> {
    auto it = args.find(flag);
    if (it == args.end()) return std::nullopt;
    std::string v = it->second;
    args.erase(it);
    return v;
  };

  const bool two_lobes = args.count("--diffuse") || args.count("--specular");
  if (two_lobes && args.count("--model")) {
    throw UsageError("--model: give either --model or --diffuse and --specular (a two-lobe material), not both");
  }
  if (two_lobes) {
    cmd.material = parse_material(take);
    cmd.spec = cmd.material->specular;
  } else {
    const auto model = take("--model");
    if (!model) throw UsageError("--model: missing; expected one of " + model_names());
    cmd.spec = parse_model(take, "--model", *model, "");
  }

  for (const char* flag : {"--wo", "--wi", "--mu", "--samples", "--n-mu", "--n-roughness", "--seed"}) {
    if (auto v = take(flag)) cmd.options[flag] = *v;
  }
  if (!args.empty()) throw UsageError("unknown option '" + args.begin()->first + "' (see --help)");
  return cmd;
}

std::string values(const Rgb& c) {
  if (c.r == c.g && c.g == c.b) return format_number(c.r);
  return format_number(c.r) + " " + format_number(c.g) + " " + format_number(c.b);
}

std::string csv(const Rgb& c) { return format_number(c.r) + "," + format_number(c.g) + "," + format_number(c.b); }

AlbedoOptions albedo_options(const Command& cmd, int default_samples) {
  AlbedoOptions o;
  o.samples = default_samples;
  if (auto it = cmd.options.find("--samples"); it != cmd.options.end()) {
    o.samples = parse_count("--samples", it->second, 16, 1 << 26);
  }
  if (auto it = cmd.options.find("--seed"); it != cmd.options.end()) {
    o.seed = static_cast<uint64_t>(parse_count("--seed", it->second, 0, 1 << 30));
  }
  return o;
}

const std::string& required(const Command& cmd, const std::string& flag, const std::string& what) {
  auto it = cmd.options.find(flag);
  if (it == cmd.options.end()) throw UsageError(flag + ": missing; " + cmd.name + " needs " + what);
  return it->second;
}

int run(const Command& cmd) {
  const std::unique_ptr<Bxdf> bxdf = cmd.material ? std::make_unique<Material>(*cmd.material) : make_bxdf(cmd.spec);
  if (cmd.name == "eval") {
    const Vec3 wo = parse_direction("--wo", required(cmd, "--wo", "the outgoing direction x,y,z"));
    const Vec3 wi = parse_direction("--wi", required(cmd, "--wi", "the incident direction x,y,z"));
    std::cout << values(bxdf->eval(wo, wi)) << "\n";
    return 0;
  }
  if (cmd.name == "albedo") {
    const double mu = parse_number("--mu", required(cmd, "--mu", "the cosine of the outgoing angle"));
    if (!(mu > 0 && mu <= 1)) throw UsageError("--mu: must be in (0, 1], got " + format_number(mu));
    const Estimate e = directional_albedo(*bxdf, mu, albedo_options(cmd, 65536));
    std::cout << values(e.value) << "\n";
    std::cout << "std_error " << values(e.std_error) << " samples " << e.samples << "\n";
    return 0;
  }
  // table
  const AlbedoOptions options = albedo_options(cmd, 4096);
  int n_mu = 32, n_roughness = 32;
  if (auto it = cmd.options.find("--n-mu"); it != cmd.options.end()) n_mu = parse_count("--n-mu", it->second, 1, 1024);
  if (auto it = cmd.options.find("--n-roughness"); it != cmd.options.end()) {
    n_roughness = parse_count("--n-roughness", it->second, 1, 1024);
  }
  const AlbedoTable table = albedo_table(*bxdf, n_mu, options);
  std::cout << "# kiln-brdf table: " << bxdf->describe() << "\n";
  std::cout << "# directional albedo E(mu), mu = cos(theta_o) at texel centres, averaged over the azimuth of wo\n";
  std::cout << "mu,E_r,E_g,E_b,std_error_r,std_error_g,std_error_b,samples\n";
  for (size_t i = 0; i < table.mu.size(); ++i) {
    const Estimate& e = table.e[i];
    std::cout << format_number(table.mu[i]) << "," << csv(e.value) << "," << csv(e.std_error) << "," << e.samples
              << "\n";
  }
  std::cout << "average," << csv(table.average.value) << "," << csv(table.average.std_error) << ","
            << table.average.samples << "\n\n";
  const SplitSumTable ss = split_sum_table(cmd.spec, n_mu, n_roughness, options);
  std::cout << "# split-sum table of the white " << (cmd.material ? "specular lobe" : "model")
            << " without Fresnel: E ~= f0 * scale + bias; roughness is " << roughness_name(cmd.spec.model) << "\n";
  std::cout << "roughness,mu,scale,bias,scale_std_error,bias_std_error\n";
  for (int j = 0; j < ss.n_roughness; ++j) {
    for (int i = 0; i < ss.n_mu; ++i) {
      const int k = j * ss.n_mu + i;
      std::cout << format_number(ss.roughness[j]) << "," << format_number(ss.mu[i]) << "," << format_number(ss.scale[k])
                << "," << format_number(ss.bias[k]) << "," << format_number(ss.scale_error[k]) << ","
                << format_number(ss.bias_error[k]) << "\n";
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h" || a == "help") {
      std::cout << kUsage;
      return 0;
    }
  }
  try {
    return run(parse_command(argc, argv));
  } catch (const UsageError& e) {
    std::cerr << "kiln-brdf: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "kiln-brdf: " << e.what() << "\n";
    return 1;
  }
}
