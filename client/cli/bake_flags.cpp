#include "client/cli/bake_flags.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "client/cli/job_flags.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {

const char* const kBakeMaterialHelp = R"(usage: kiln bake material --model MODEL [parameters] --out DIR [options]
       kiln bake material --diffuse MODEL --specular MODEL [material] [lobe parameters] --out DIR [options]

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
a two-lobe material (the model lightmaps shade with), instead of --model:
  --diffuse MODEL --specular MODEL   its lobes, each one of the models (usually lambert or oren-nayar, and ggx)
  --combine layered|weights    layered (default): the diffuse lobe gets what the specular one does not reflect;
                               weights: (1 - s) diffuse + s specular
  --specular-weight S          s for --combine weights, [0, 1]; default 0.5
  --diffuse-PARAM V, --specular-PARAM V   a lobe's parameters, the flags above with the lobe's name before them:
                               --diffuse-albedo 0.8 --specular-alpha 0.3 --specular-fresnel schlick --specular-f0 0.04
                               (split_sum.exr is then the specular lobe's)
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

examples:
  kiln bake material --model ggx --alpha 0.3 --fresnel schlick --f0 0.04 --out out/ggx
  kiln bake material --diffuse lambert --diffuse-albedo 0.5,0.3,0.2 --specular ggx --specular-alpha 0.2 \
    --specular-fresnel schlick --specular-f0 0.04 --out out/layered
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

// A model's parameter flags without their dashes, in the order the default name lists them.
const char* const kParameters[] = {
    "albedo",       "sigma",   "interreflection", "alpha", "alpha-x", "alpha-y", "fresnel",  "f0",       "eta",
    "distribution", "masking", "normalization",   "c",     "r",       "p",       "bottom-c", "bottom-r", "bottom-p"};
// A two-lobe material's own flags.
const char* const kMaterialFlags[] = {"--diffuse", "--specular", "--combine", "--specular-weight"};
// The flags that describe the job besides the model's: the tables and the quality.
const char* const kTableFlags[] = {"--samples", "--target-error", "--time-limit",
                                   "--seed",    "--table-mu",     "--table-roughness"};

// Every flag that describes the job, in the order the default name lists them: a single model's parameters
// ("--alpha"), the material's flags, each lobe's parameters ("--diffuse-albedo", "--specular-alpha"), the tables'.
const std::vector<const char*>& job_flags() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const char* prefix : {"--", "--diffuse-", "--specular-"}) {
      if (std::string(prefix) == "--diffuse-")
        out.insert(out.end(), std::begin(kMaterialFlags), std::end(kMaterialFlags));
      for (const char* p : kParameters) out.push_back(prefix + std::string(p));
    }
    out.insert(out.end(), std::begin(kTableFlags), std::end(kTableFlags));
    return out;
  }();
  static const std::vector<const char*> flags = [] {
    std::vector<const char*> out;
    for (const std::string& n : names) out.push_back(n.c_str());
    return out;
  }();
  return flags;
}

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

// The parameter flags of one model take `p` before their name: "--" for a single model ("--alpha"), "--diffuse-" or
// "--specular-" for a lobe of a two-lobe material ("--specular-alpha").
void microfacet(const Flags& f, const std::string& p, Model model, const std::string& model_name, v1::Microfacet* m) {
  const std::string alpha = p + "alpha", alpha_x = p + "alpha-x", alpha_y = p + "alpha-y";
  const bool anisotropic = f.has(alpha_x) || f.has(alpha_y);
  if (f.has(alpha) && anisotropic) {
    throw UsageError(alpha + ": give either " + alpha + " or " + alpha_x + " and " + alpha_y + ", not both");
  }
  if (anisotropic && !(f.has(alpha_x) && f.has(alpha_y))) {
    throw UsageError((f.has(alpha_x) ? alpha_y : alpha_x) + ": missing; " + alpha_x + " and " + alpha_y +
                     " go together");
  }
  if (auto v = f.get(alpha)) m->set_alpha(parse_number_in(alpha, *v, bounds::kAlpha));
  if (auto v = f.get(alpha_x)) m->set_alpha_x(parse_number_in(alpha_x, *v, bounds::kAlpha));
  if (auto v = f.get(alpha_y)) m->set_alpha_y(parse_number_in(alpha_y, *v, bounds::kAlpha));

  // The Fresnel term in force, so that --f0 and --eta are refused where the model would ignore them.
  const std::string fresnel_flag = p + "fresnel", f0 = p + "f0", eta = p + "eta";
  std::string fresnel = model == Model::cook_torrance ? "exact" : "none";
  if (auto v = f.get(fresnel_flag)) {
    m->set_fresnel(parse_choice<v1::Fresnel>(
        fresnel_flag, *v,
        {{"none", v1::FRESNEL_NONE}, {"schlick", v1::FRESNEL_SCHLICK}, {"exact", v1::FRESNEL_EXACT}}));
    fresnel = hyphenated(*v);
  }
  const std::string in_force =
      f.has(fresnel_flag) ? fresnel_flag + " " + fresnel : model_name + "'s default Fresnel term (" + fresnel + ")";
  if (auto v = f.get(f0)) {
    if (fresnel != "schlick") {
      throw UsageError(f0 + ": only " + fresnel_flag + " schlick uses it, and " + in_force + " would ignore it; add " +
                       fresnel_flag + " schlick");
    }
    set_color(f0, *v, m->mutable_f0());
  }
  if (auto v = f.get(eta)) {
    if (fresnel != "exact") {
      throw UsageError(eta + ": only exact Fresnel uses it, and " + in_force + " would ignore it; add " + fresnel_flag +
                       " exact");
    }
    m->set_eta(parse_number_in(eta, *v, bounds::kEta));
  }
  if (auto v = f.get(p + "distribution")) {
    m->set_distribution(parse_choice<v1::Distribution>(p + "distribution", *v,
                                                       {{"ggx", v1::DISTRIBUTION_GGX},
                                                        {"beckmann", v1::DISTRIBUTION_BECKMANN},
                                                        {"schlick-beckmann", v1::DISTRIBUTION_SCHLICK_BECKMANN}}));
  }
  if (auto v = f.get(p + "masking")) {
    m->set_masking(parse_choice<v1::Masking>(p + "masking", *v,
                                             {{"separable", v1::MASKING_SEPARABLE},
                                              {"height-correlated", v1::MASKING_HEIGHT_CORRELATED},
                                              {"v-groove", v1::MASKING_V_GROOVE},
                                              {"schlick", v1::MASKING_SCHLICK}}));
  }
  if (auto v = f.get(p + "normalization")) {
    m->set_normalization(parse_choice<v1::Normalization>(
        p + "normalization", *v, {{"4", v1::NORMALIZATION_FOUR}, {"pi", v1::NORMALIZATION_PI}}));
  }
}

void schlick_layer(const Flags& f, const std::string& prefix, v1::SchlickLayer* l) {
  const std::string c = prefix + "c", r = prefix + "r", p = prefix + "p";
  if (auto v = f.get(c)) set_color(c, *v, l->mutable_c());
  if (auto v = f.get(r)) l->set_r(parse_number_in(r, *v, bounds::kSchlickParameter));
  if (auto v = f.get(p)) l->set_p(parse_number_in(p, *v, bounds::kSchlickParameter));
}

void oren_nayar(const Flags& f, const std::string& p, Model model, v1::OrenNayar* on) {
  const std::string albedo = p + "albedo", sigma = p + "sigma", inter = p + "interreflection";
  if (auto v = f.get(albedo)) set_color(albedo, *v, on->mutable_albedo());
  if (auto v = f.get(sigma)) on->set_sigma(parse_number_in(sigma, *v, bounds::kSigma));
  if (auto v = f.get(inter)) {
    if (*v != "on" && *v != "off") throw UsageError(inter + ": expected on or off, got '" + *v + "'");
    if (*v == "on" && model != Model::oren_nayar) {
      throw UsageError(inter + ": the two-bounce term belongs to the full model; use " +
                       (p == "--" ? std::string("--model") : p.substr(0, p.size() - 1)) + " oren-nayar");
    }
    on->set_interreflection(*v == "on");
  }
}

// The model's own parameters (the flags were already checked to belong to it), into a MaterialJob or a Brdf (a
// lobe of a layered material): the two share their oneof's names.
template <class Message>
void set_model_fields(const Flags& f, const std::string& p, Model model, const std::string& model_name, Message* job) {
  switch (model) {
    case Model::lambert:
      if (auto v = f.get(p + "albedo")) set_color(p + "albedo", *v, job->mutable_lambert()->mutable_albedo());
      job->mutable_lambert();
      break;
    case Model::oren_nayar:
      oren_nayar(f, p, model, job->mutable_oren_nayar());
      break;
    case Model::oren_nayar_simple:
      oren_nayar(f, p, model, job->mutable_oren_nayar_simple());
      break;
    case Model::cook_torrance:
      microfacet(f, p, model, model_name, job->mutable_cook_torrance());
      break;
    case Model::ggx:
      microfacet(f, p, model, model_name, job->mutable_ggx());
      break;
    case Model::beckmann:
      microfacet(f, p, model, model_name, job->mutable_beckmann());
      break;
    case Model::schlick:
    case Model::schlick_double: {
      // kiln-brdf takes --albedo as the Schlick layer's reflection factor; so does this.
      if (f.has(p + "albedo") && f.has(p + "c")) {
        throw UsageError(p + "albedo: give " + p + "albedo or " + p + "c, not both");
      }
      v1::SchlickLayer* top =
          model == Model::schlick ? job->mutable_schlick() : job->mutable_schlick_double()->mutable_top();
      if (auto v = f.get(p + "albedo")) set_color(p + "albedo", *v, top->mutable_c());
      schlick_layer(f, p, top);
      if (model == Model::schlick_double) {
        schlick_layer(f, p + "bottom-", job->mutable_schlick_double()->mutable_bottom());
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
  return model_name + given_flag_words(f, job_flags()) + (f.has("--merl") ? " merl" : "");
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

// --model's or a lobe's (--diffuse, --specular) model name.
Model model_from_flag(const Flags& f, const std::string& flag) {
  const auto text = f.get(flag);
  if (!text) throw UsageError(flag + ": missing; expected one of " + model_names());
  const auto found =
      std::find_if(kModels.begin(), kModels.end(), [&](const ModelName& m) { return hyphenated(*text) == m.name; });
  if (found == kModels.end()) throw UsageError(flag + ": expected one of " + model_names() + ", got '" + *text + "'");
  return found->model;
}

const char* model_name(Model m) {
  return std::find_if(kModels.begin(), kModels.end(), [&](const ModelName& n) { return n.model == m; })->name;
}

// A parameter flag given to a model without that parameter is an error rather than silently ignored.
void check_parameters_apply(const Flags& f, const std::string& p, const std::string& model_flag, Model model) {
  for (const auto& a : kApplies) {
    const std::string flag = p + (a.flag + 2);
    if (f.has(flag) && !a.applies(model)) {
      throw UsageError(flag + ": " + model_flag + " " + model_name(model) + " has no such parameter (" + flag +
                       " is for " + a.models + ")");
    }
  }
}

// --diffuse MODEL --specular MODEL [--combine] [--specular-weight] and the lobes' parameters, into job.layered.
std::string set_layered_fields(const Flags& f, v1::MaterialJob* job) {
  if (f.has("--model")) {
    throw UsageError("--model: give either --model or --diffuse and --specular (a two-lobe material), not both");
  }
  for (const char* p : kParameters) {
    if (f.has("--" + std::string(p))) {
      throw UsageError("--" + std::string(p) + ": a two-lobe material takes its lobes' parameters as --diffuse-" + p +
                       " or --specular-" + p);
    }
  }
  if (!f.has("--diffuse") || !f.has("--specular")) {
    throw UsageError(std::string(f.has("--diffuse") ? "--specular" : "--diffuse") +
                     ": missing; a two-lobe material needs both --diffuse MODEL and --specular MODEL");
  }
  v1::Layered* layered = job->mutable_layered();
  const Model diffuse = model_from_flag(f, "--diffuse"), specular = model_from_flag(f, "--specular");
  check_parameters_apply(f, "--diffuse-", "--diffuse", diffuse);
  check_parameters_apply(f, "--specular-", "--specular", specular);
  set_model_fields(f, "--diffuse-", diffuse, model_name(diffuse), layered->mutable_diffuse());
  set_model_fields(f, "--specular-", specular, model_name(specular), layered->mutable_specular());
  std::string combine = "layered";
  if (auto v = f.get("--combine")) {
    layered->set_combine(parse_choice<v1::Combine>(
        "--combine", *v, {{"layered", v1::COMBINE_LAYERED}, {"weights", v1::COMBINE_WEIGHTS}}));
    combine = hyphenated(*v);
  }
  if (auto v = f.get("--specular-weight")) {
    if (combine != "weights") throw UsageError("--specular-weight: applies to --combine weights only");
    layered->set_specular_weight(parse_number_in("--specular-weight", *v, bounds::kSpecularWeight));
  }
  return combine + " " + model_name(diffuse) + "+" + model_name(specular);
}

}  // namespace

std::vector<FlagSpec> bake_material_flag_specs() {
  return bake_flag_specs({"--model", "--name", "--out", "--priority", "--idempotency-key"}, job_flags(),
                         {"--merl", "--no-preview"});
}

v1::JobSpec material_spec_from_flags(const std::vector<std::string>& args) {
  return material_spec_from_flags(parse_flags(args, bake_material_flag_specs(), "kiln bake material"));
}

v1::JobSpec material_spec_from_flags(const Flags& f) {
  v1::JobSpec spec;
  v1::MaterialJob* job = spec.mutable_material();
  std::string name;
  const bool two_lobes = std::any_of(std::begin(kMaterialFlags), std::end(kMaterialFlags),
                                     [&](const char* flag) { return f.has(flag); }) ||
                         std::any_of(job_flags().begin(), job_flags().end(), [&](const char* flag) {
                           const std::string s(flag);
                           return f.has(s) && (s.rfind("--diffuse-", 0) == 0 || s.rfind("--specular-", 0) == 0);
                         });
  if (two_lobes) {
    name = set_layered_fields(f, job);
  } else {
    const Model model = model_from_flag(f, "--model");
    check_parameters_apply(f, "--", "--model", model);
    name = model_name(model);
    set_model_fields(f, "--", model, name, job);
  }
  set_tables_and_quality(f, spec);
  add_forced_effects(f, spec);
  set_name(f, spec, default_name(f, name));
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
  // A lobe of a layered material: job.material.layered.{diffuse,specular}.MODEL.FIELD takes --diffuse-FIELD's flag.
  const bool layered = parts.size() >= 3 && parts[1] == "material" && parts[2] == "layered";
  if (layered && parts.size() == 3) return "";
  if (layered && parts.size() == 4) {
    if (parts[3] == "combine") return "--combine";
    if (parts[3] == "specular_weight") return "--specular-weight";
    return "--" + parts[3];  // a lobe as a whole: its model
  }
  const std::string p = layered ? "--" + parts[3] + "-" : "--";
  const bool bottom = std::find(parts.begin(), parts.end(), "bottom") != parts.end();
  if (last == "c" || last == "r" || last == "p") return p + (bottom ? "bottom-" : "") + last;
  for (const auto& [field, flag] : kFieldFlags) {
    if (last == field) return layered ? p + (flag + 2) : flag;
  }
  return "";
}

}  // namespace kiln::cli
