#include "client/cli/bake_flags.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "client/cli/job_flags.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {

const char* const kBakeMaterialHelp = R"(usage: kiln bake material --model MODEL [parameters] --out DIR [options]

Bakes one material on the server, waits for it with a progress display, and writes every output (albedo.exr,
split_sum.exr, brdf.merl with --merl, preview.png) and report.json into DIR. Prints where they went and what the
bake cost.
Ctrl-C cancels the job on the server (a second Ctrl-C leaves it running and exits at once).
The flags are those of kiln-brdf; they become a kiln.v1.JobSpec (see client/examples/ for the same as job files).

models: lambert, oren-nayar, oren-nayar-simple, cook-torrance, ggx, beckmann, schlick, schlick-double
parameters (a model refuses the parameters it does not have; unset ones take the server's defaults):
  --albedo A | R,G,B           diffuse reflectance, [0, 1] (lambert, oren-nayar*; for schlick* the same as --c)
  --sigma S                    Oren-Nayar facet slope deviation in radians, [0, pi/2]
  --interreflection on|off     Oren-Nayar two-bounce term (oren-nayar only)
  --alpha A                    microfacet width as in the formula (GGX alpha, Beckmann m), (0, 1]
  --alpha-x A --alpha-y A      anisotropic widths along the tangent and the bitangent, instead of --alpha
  --fresnel none|schlick|exact Fresnel term; default exact for cook-torrance, none (the white furnace) otherwise
  --f0 F | R,G,B               reflectance at normal incidence, [0, 1]; needs --fresnel schlick
  --eta ETA                    relative index of refraction, [0.1, 10]; needs exact Fresnel
  --distribution ggx|beckmann|schlick-beckmann           override the model's D
  --masking separable|height-correlated|v-groove|schlick  override the model's G
  --normalization 4|pi         microfacet denominator 4(n.i)(n.o) or the original Cook-Torrance pi(n.i)(n.o)
  --c C | R,G,B  --r R  --p P  Schlick layer (the top one for schlick-double): reflection factor, roughness,
                               isotropy, each in [0, 1]
  --bottom-c C --bottom-r R --bottom-p P   schlick-double: the bottom layer
quality and tables:
  --samples N                  samples per table entry, [1, 16777216]; with --target-error, the cap
  --target-error E             stop refining an entry once its standard error is below E, (0, 1]
  --time-limit S               stop refining after S seconds, reporting the error reached, (0, 86400]
  --seed N                     random seed; the same spec and seed give the same bytes
  --table-mu N                 albedo table resolution along mu = cos(theta_o), [2, 1024]
  --table-roughness N          split-sum table resolution along roughness, [2, 1024]
  --merl                       also tabulate the BRDF in the MERL binary layout (brdf.merl, 35 MB)
  --no-preview                 leave out preview.png (spheres of the material under a studio and a sun, and its
                               white-furnace form)
  --force EFFECT=on|off        make the planner simulate or skip an effect (repeatable; material: merl)
  --name TEXT                  a name for people in `kiln jobs` (default: the model and its flags)
options:
  --out DIR                    where the outputs and report.json go (required; created if missing)
  --priority N                 higher runs first, [-100, 100]; default 0
  --idempotency-key KEY        resubmitting with the same key and spec returns the first job
  --server HOST:PORT | unix:PATH, --token-file FILE, --tls-ca FILE   see `kiln --help`

example:
  kiln bake material --model ggx --alpha 0.3 --fresnel schlick --f0 0.04 --out out/ggx
)";

namespace {

enum class Model { lambert, oren_nayar, oren_nayar_simple, cook_torrance, ggx, beckmann, schlick, schlick_double };

struct ModelName {
  Model model;
  const char* name;
};
constexpr std::array<ModelName, 8> kModels{{{Model::lambert, "lambert"},
                                            {Model::oren_nayar, "oren-nayar"},
                                            {Model::oren_nayar_simple, "oren-nayar-simple"},
                                            {Model::cook_torrance, "cook-torrance"},
                                            {Model::ggx, "ggx"},
                                            {Model::beckmann, "beckmann"},
                                            {Model::schlick, "schlick"},
                                            {Model::schlick_double, "schlick-double"}}};

std::string model_names() {
  std::string out;
  for (const auto& m : kModels) out += (out.empty() ? "" : ", ") + std::string(m.name);
  return out;
}

bool is_microfacet(Model m) { return m == Model::cook_torrance || m == Model::ggx || m == Model::beckmann; }
bool is_oren_nayar(Model m) { return m == Model::oren_nayar || m == Model::oren_nayar_simple; }
bool is_schlick(Model m) { return m == Model::schlick || m == Model::schlick_double; }

// Which models have each parameter flag; a flag given to another model is an error rather than silently ignored.
struct Applies {
  const char* flag;
  bool (*applies)(Model);
  const char* models;  // for the error message
};
const Applies kApplies[] = {
    {"--albedo", [](Model m) { return m == Model::lambert || is_oren_nayar(m) || is_schlick(m); },
     "lambert, oren-nayar, oren-nayar-simple, schlick, schlick-double"},
    {"--sigma", is_oren_nayar, "oren-nayar, oren-nayar-simple"},
    {"--interreflection", is_oren_nayar, "oren-nayar"},
    {"--alpha", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--alpha-x", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--alpha-y", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--fresnel", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--f0", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--eta", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--distribution", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--masking", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--normalization", is_microfacet, "cook-torrance, ggx, beckmann"},
    {"--c", is_schlick, "schlick, schlick-double"},
    {"--r", is_schlick, "schlick, schlick-double"},
    {"--p", is_schlick, "schlick, schlick-double"},
    {"--bottom-c", [](Model m) { return m == Model::schlick_double; }, "schlick-double"},
    {"--bottom-r", [](Model m) { return m == Model::schlick_double; }, "schlick-double"},
    {"--bottom-p", [](Model m) { return m == Model::schlick_double; }, "schlick-double"},
};

// The flags that describe the job, in the order the default name lists them.
const char* const kJobFlags[] = {"--albedo",
                                 "--sigma",
                                 "--interreflection",
                                 "--alpha",
                                 "--alpha-x",
                                 "--alpha-y",
                                 "--fresnel",
                                 "--f0",
                                 "--eta",
                                 "--distribution",
                                 "--masking",
                                 "--normalization",
                                 "--c",
                                 "--r",
                                 "--p",
                                 "--bottom-c",
                                 "--bottom-r",
                                 "--bottom-p",
                                 "--samples",
                                 "--target-error",
                                 "--time-limit",
                                 "--seed",
                                 "--table-mu",
                                 "--table-roughness"};

void set_color(const std::string& flag, const std::string& text, v1::Color* c) {
  parse_color(flag, text, bounds::kReflectance, c);
}

template <typename Enum>
Enum parse_choice(const std::string& flag, const std::string& text,
                  std::initializer_list<std::pair<const char*, Enum>> choices) {
  std::string names;
  for (const auto& [name, value] : choices) {
    if (hyphenated(text) == name) return value;
    names += (names.empty() ? "" : ", ") + std::string(name);
  }
  throw UsageError(flag + ": expected one of " + names + ", got '" + text + "'");
}

void microfacet(const Flags& f, Model model, const std::string& model_name, v1::Microfacet* m) {
  const bool anisotropic = f.has("--alpha-x") || f.has("--alpha-y");
  if (f.has("--alpha") && anisotropic) {
    throw UsageError("--alpha: give either --alpha or --alpha-x and --alpha-y, not both");
  }
  if (anisotropic && !(f.has("--alpha-x") && f.has("--alpha-y"))) {
    throw UsageError(std::string(f.has("--alpha-x") ? "--alpha-y" : "--alpha-x") +
                     ": missing; --alpha-x and --alpha-y go together");
  }
  if (auto v = f.get("--alpha")) m->set_alpha(parse_number_in("--alpha", *v, bounds::kAlpha));
  if (auto v = f.get("--alpha-x")) m->set_alpha_x(parse_number_in("--alpha-x", *v, bounds::kAlpha));
  if (auto v = f.get("--alpha-y")) m->set_alpha_y(parse_number_in("--alpha-y", *v, bounds::kAlpha));

  // The Fresnel term in force, so that --f0 and --eta are refused where the model would ignore them.
  std::string fresnel = model == Model::cook_torrance ? "exact" : "none";
  if (auto v = f.get("--fresnel")) {
    m->set_fresnel(parse_choice<v1::Fresnel>(
        "--fresnel", *v, {{"none", v1::FRESNEL_NONE}, {"schlick", v1::FRESNEL_SCHLICK}, {"exact", v1::FRESNEL_EXACT}}));
    fresnel = hyphenated(*v);
  }
  const std::string in_force =
      f.has("--fresnel") ? "--fresnel " + fresnel : model_name + "'s default Fresnel term (" + fresnel + ")";
  if (auto v = f.get("--f0")) {
    if (fresnel != "schlick") {
      throw UsageError("--f0: only --fresnel schlick uses it, and " + in_force +
                       " would ignore it; add --fresnel schlick");
    }
    set_color("--f0", *v, m->mutable_f0());
  }
  if (auto v = f.get("--eta")) {
    if (fresnel != "exact") {
      throw UsageError("--eta: only exact Fresnel uses it, and " + in_force + " would ignore it; add --fresnel exact");
    }
    m->set_eta(parse_number_in("--eta", *v, bounds::kEta));
  }
  if (auto v = f.get("--distribution")) {
    m->set_distribution(parse_choice<v1::Distribution>("--distribution", *v,
                                                       {{"ggx", v1::DISTRIBUTION_GGX},
                                                        {"beckmann", v1::DISTRIBUTION_BECKMANN},
                                                        {"schlick-beckmann", v1::DISTRIBUTION_SCHLICK_BECKMANN}}));
  }
  if (auto v = f.get("--masking")) {
    m->set_masking(parse_choice<v1::Masking>("--masking", *v,
                                             {{"separable", v1::MASKING_SEPARABLE},
                                              {"height-correlated", v1::MASKING_HEIGHT_CORRELATED},
                                              {"v-groove", v1::MASKING_V_GROOVE},
                                              {"schlick", v1::MASKING_SCHLICK}}));
  }
  if (auto v = f.get("--normalization")) {
    m->set_normalization(parse_choice<v1::Normalization>(
        "--normalization", *v, {{"4", v1::NORMALIZATION_FOUR}, {"pi", v1::NORMALIZATION_PI}}));
  }
}

void schlick_layer(const Flags& f, const std::string& prefix, v1::SchlickLayer* l) {
  const std::string c = prefix + "c", r = prefix + "r", p = prefix + "p";
  if (auto v = f.get(c)) set_color(c, *v, l->mutable_c());
  if (auto v = f.get(r)) l->set_r(parse_number_in(r, *v, bounds::kSchlickParameter));
  if (auto v = f.get(p)) l->set_p(parse_number_in(p, *v, bounds::kSchlickParameter));
}

void oren_nayar(const Flags& f, Model model, v1::OrenNayar* on) {
  if (auto v = f.get("--albedo")) set_color("--albedo", *v, on->mutable_albedo());
  if (auto v = f.get("--sigma")) on->set_sigma(parse_number_in("--sigma", *v, bounds::kSigma));
  if (auto v = f.get("--interreflection")) {
    if (*v != "on" && *v != "off") throw UsageError("--interreflection: expected on or off, got '" + *v + "'");
    if (*v == "on" && model != Model::oren_nayar) {
      throw UsageError("--interreflection: the two-bounce term belongs to the full model; use --model oren-nayar");
    }
    on->set_interreflection(*v == "on");
  }
}

// The model's own parameters (the flags were already checked to belong to it).
void set_model_fields(const Flags& f, Model model, const std::string& model_name, v1::MaterialJob* job) {
  switch (model) {
    case Model::lambert:
      if (auto v = f.get("--albedo")) set_color("--albedo", *v, job->mutable_lambert()->mutable_albedo());
      job->mutable_lambert();
      break;
    case Model::oren_nayar:
      oren_nayar(f, model, job->mutable_oren_nayar());
      break;
    case Model::oren_nayar_simple:
      oren_nayar(f, model, job->mutable_oren_nayar_simple());
      break;
    case Model::cook_torrance:
      microfacet(f, model, model_name, job->mutable_cook_torrance());
      break;
    case Model::ggx:
      microfacet(f, model, model_name, job->mutable_ggx());
      break;
    case Model::beckmann:
      microfacet(f, model, model_name, job->mutable_beckmann());
      break;
    case Model::schlick:
    case Model::schlick_double: {
      // kiln-brdf takes --albedo as the Schlick layer's reflection factor; so does this.
      if (f.has("--albedo") && f.has("--c")) throw UsageError("--albedo: give --albedo or --c, not both");
      v1::SchlickLayer* top =
          model == Model::schlick ? job->mutable_schlick() : job->mutable_schlick_double()->mutable_top();
      if (auto v = f.get("--albedo")) set_color("--albedo", *v, top->mutable_c());
      schlick_layer(f, "--", top);
      if (model == Model::schlick_double) {
        schlick_layer(f, "--bottom-", job->mutable_schlick_double()->mutable_bottom());
      }
      break;
    }
  }
}

// The table sizes, --merl, and the quality: samples, target error, time limit, seed.
void set_tables_and_quality(const Flags& f, v1::JobSpec& spec) {
  v1::MaterialJob* job = spec.mutable_material();
  if (f.has("--table-mu")) job->set_table_mu(whole_flag(f, "--table-mu", bounds::kTableSize));
  if (f.has("--table-roughness")) job->set_table_roughness(whole_flag(f, "--table-roughness", bounds::kTableSize));
  job->set_merl(f.has("--merl"));
  if (f.has("--no-preview")) job->set_preview(false);

  v1::Quality* q = spec.mutable_quality();
  if (auto v = f.get("--samples"))
    q->set_samples(static_cast<std::uint64_t>(parse_whole("--samples", *v, bounds::kMaterialSamples)));
  if (auto v = f.get("--target-error"))
    q->set_target_error(parse_number_in("--target-error", *v, bounds::kMaterialTargetError));
  if (auto v = f.get("--time-limit")) {
    q->set_time_limit_seconds(parse_number_in("--time-limit", *v, bounds::kMaterialTimeLimitSeconds));
  }
  set_seed_and_drop_empty_quality(f, spec);
}

std::string default_name(const Flags& f, const std::string& model_name) {
  return model_name + given_flag_words(f, kJobFlags) + (f.has("--merl") ? " merl" : "");
}

// The components of a field path without their [index] or [key]: "job.lights[2].color" -> job, lights, color.
std::vector<std::string> path_components(const std::string& field_path) {
  std::vector<std::string> parts;
  std::stringstream ss(field_path);
  for (std::string item; std::getline(ss, item, '.');) {
    const auto bracket = item.find('[');
    if (bracket != std::string::npos) item = item.substr(0, bracket);
    parts.push_back(item);
  }
  return parts;
}

// `kiln bake env`: the flag of job.environment.FIELD; none for the image, which is the command's argument.
std::string environment_flag_for(const std::vector<std::string>& parts) {
  static const std::pair<const char*, const char*> kEnvironment[] = {
      {"faces", "--faces"},
      {"constant", "--constant"},
      {"color_space", "--color-space"},
      {"rotation_degrees", "--rotation"},
      {"intensity", "--intensity"},
      {"lobe", "--lobe"},
      {"size", "--size"},
      {"levels", "--levels"},
      {"irradiance_size", "--irradiance-size"},
      {"dfg_size", "--dfg-size"},
      {"dfg_samples", "--dfg-samples"},
      {"dfg_masking", "--dfg-masking"},
      {"preview", "--no-preview"},
  };
  if (parts.size() == 2) return "";
  for (const auto& [field, flag] : kEnvironment) {
    if (parts[2] == field) return flag;
  }
  return "";
}

// The material and quality fields that a flag of the same name sets.
const std::pair<const char*, const char*> kFieldFlags[] = {
    {"albedo", "--albedo"},
    {"sigma", "--sigma"},
    {"interreflection", "--interreflection"},
    {"alpha", "--alpha"},
    {"alpha_x", "--alpha-x"},
    {"alpha_y", "--alpha-y"},
    {"fresnel", "--fresnel"},
    {"f0", "--f0"},
    {"eta", "--eta"},
    {"distribution", "--distribution"},
    {"masking", "--masking"},
    {"normalization", "--normalization"},
    {"table_mu", "--table-mu"},
    {"table_roughness", "--table-roughness"},
    {"merl", "--merl"},
    {"preview", "--no-preview"},
    {"samples", "--samples"},
    {"target_error", "--target-error"},
    {"time_limit_seconds", "--time-limit"},
    {"seed", "--seed"},
};

}  // namespace

std::vector<FlagSpec> bake_material_flag_specs() {
  return bake_flag_specs({"--model", "--name", "--out", "--priority", "--idempotency-key"}, kJobFlags, {"--merl", "--no-preview"});
}

v1::JobSpec material_spec_from_flags(const std::vector<std::string>& args) {
  return material_spec_from_flags(parse_flags(args, bake_material_flag_specs(), "kiln bake material"));
}

v1::JobSpec material_spec_from_flags(const Flags& f) {
  const auto model_text = f.get("--model");
  if (!model_text) throw UsageError("--model: missing; expected one of " + model_names());
  const auto found = std::find_if(kModels.begin(), kModels.end(),
                                  [&](const ModelName& m) { return hyphenated(*model_text) == m.name; });
  if (found == kModels.end()) {
    throw UsageError("--model: expected one of " + model_names() + ", got '" + *model_text + "'");
  }
  const Model model = found->model;
  const std::string model_name = found->name;
  for (const auto& a : kApplies) {
    if (f.has(a.flag) && !a.applies(model)) {
      throw UsageError(std::string(a.flag) + ": --model " + model_name + " has no such parameter (" + a.flag +
                       " is for " + a.models + ")");
    }
  }

  v1::JobSpec spec;
  v1::MaterialJob* job = spec.mutable_material();
  set_model_fields(f, model, model_name, job);
  set_tables_and_quality(f, spec);
  add_forced_effects(f, spec);
  set_name(f, spec, default_name(f, model_name));
  return spec;
}

std::string flag_for_field(const std::string& field_path) {
  std::vector<std::string> parts = path_components(field_path);
  if (parts.empty() || parts[0] != "job") return "";
  if (std::find(parts.begin(), parts.end(), "force_effects") != parts.end()) return "--force";
  if (parts.size() == 2 && parts[1] == "name") return "--name";
  if (parts.size() == 2 && parts[1] == "material") return "--model";  // no model given
  if (parts.size() >= 2 && parts[1] == "environment") return environment_flag_for(parts);
  std::string last = parts.back();
  // A colour channel: the colour's flag ("albedo.r" is red, but "schlick.r" is roughness).
  if ((last == "r" || last == "g" || last == "b") && parts.size() >= 2) {
    const std::string& parent = parts[parts.size() - 2];
    if (parent == "albedo" || parent == "f0" || parent == "c") {
      parts.pop_back();
      last = parent;
    }
  }
  const bool bottom = std::find(parts.begin(), parts.end(), "bottom") != parts.end();
  if (last == "c" || last == "r" || last == "p") return (bottom ? "--bottom-" : "--") + last;
  for (const auto& [field, flag] : kFieldFlags) {
    if (last == field) return flag;
  }
  return "";
}

}  // namespace kiln::cli
