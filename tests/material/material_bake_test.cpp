// The material bake: exact tables for Lambert, a GGX bake that reaches its target error and agrees with independent
// estimates, cancel, progress, the JSON report, and errors that name the field.
#include "bakers/material/material_bake.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "bakers/brdf/bxdf.h"
#include "bakers/image/exr.h"
#include "bakers/material/merl.h"

namespace kiln::material {
namespace {

// --- A small JSON reader: validates the grammar (RFC 8259) and records every object key by its path. -------------

class JsonChecker {
 public:
  explicit JsonChecker(const std::string& text) : s_(text) {}
  // True when the whole text is one valid JSON value; paths() then lists "a", "a.b", "a.list[].c", ...
  bool parse() {
    skip_ws();
    if (!value("")) return false;
    skip_ws();
    return pos_ == s_.size();
  }
  const std::set<std::string>& paths() const { return paths_; }
  const std::map<std::string, std::string>& scalars() const { return scalars_; }
  size_t error_at() const { return pos_; }

 private:
  void skip_ws() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\n' || s_[pos_] == '\r' || s_[pos_] == '\t')) ++pos_;
  }
  bool literal(const char* word) {
    const std::string w(word);
    if (s_.compare(pos_, w.size(), w) != 0) return false;
    pos_ += w.size();
    return true;
  }
  bool string(std::string* out) {
    if (pos_ >= s_.size() || s_[pos_] != '"') return false;
    ++pos_;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      const auto c = static_cast<unsigned char>(s_[pos_]);
      if (c < 0x20) return false;  // control characters must be escaped
      if (c == '\\') {
        if (++pos_ >= s_.size()) return false;
        const char e = s_[pos_];
        if (e == 'u') {
          for (int k = 1; k <= 4; ++k)
            if (pos_ + k >= s_.size() || !std::isxdigit(static_cast<unsigned char>(s_[pos_ + k]))) return false;
          pos_ += 4;
        } else if (std::string("\"\\/bfnrt").find(e) == std::string::npos) {
          return false;
        }
        if (out) *out += '?';
      } else if (out) {
        *out += static_cast<char>(c);
      }
      ++pos_;
    }
    if (pos_ >= s_.size()) return false;
    ++pos_;
    return true;
  }
  bool number() {
    const size_t start = pos_;
    if (pos_ < s_.size() && s_[pos_] == '-') ++pos_;
    if (pos_ >= s_.size()) return false;
    if (s_[pos_] == '0') {
      ++pos_;
    } else if (std::isdigit(static_cast<unsigned char>(s_[pos_]))) {
      while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    } else {
      return false;
    }
    if (pos_ < s_.size() && s_[pos_] == '.') {
      ++pos_;
      if (pos_ >= s_.size() || !std::isdigit(static_cast<unsigned char>(s_[pos_]))) return false;
      while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    }
    if (pos_ < s_.size() && (s_[pos_] == 'e' || s_[pos_] == 'E')) {
      ++pos_;
      if (pos_ < s_.size() && (s_[pos_] == '+' || s_[pos_] == '-')) ++pos_;
      if (pos_ >= s_.size() || !std::isdigit(static_cast<unsigned char>(s_[pos_]))) return false;
      while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    }
    return pos_ > start;
  }
  bool value(const std::string& path) {
    if (pos_ >= s_.size()) return false;
    const size_t start = pos_;
    const char c = s_[pos_];
    bool ok;
    if (c == '{')
      ok = object(path);
    else if (c == '[')
      ok = array(path);
    else if (c == '"')
      ok = string(nullptr);
    else if (c == 't')
      ok = literal("true");
    else if (c == 'f')
      ok = literal("false");
    else if (c == 'n')
      ok = literal("null");
    else
      ok = number();
    if (ok && c != '{' && c != '[') scalars_[path] = s_.substr(start, pos_ - start);
    return ok;
  }
  bool object(const std::string& path) {
    ++pos_;
    skip_ws();
    if (pos_ < s_.size() && s_[pos_] == '}') {
      ++pos_;
      return true;
    }
    while (true) {
      skip_ws();
      std::string key;
      if (!string(&key)) return false;
      const std::string child = path.empty() ? key : path + "." + key;
      paths_.insert(child);
      skip_ws();
      if (pos_ >= s_.size() || s_[pos_] != ':') return false;
      ++pos_;
      skip_ws();
      if (!value(child)) return false;
      skip_ws();
      if (pos_ < s_.size() && s_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < s_.size() && s_[pos_] == '}') {
        ++pos_;
        return true;
      }
      return false;
    }
  }
  bool array(const std::string& path) {
    ++pos_;
    skip_ws();
    if (pos_ < s_.size() && s_[pos_] == ']') {
      ++pos_;
      return true;
    }
    while (true) {
      skip_ws();
      if (!value(path + "[]")) return false;
      skip_ws();
      if (pos_ < s_.size() && s_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < s_.size() && s_[pos_] == ']') {
        ++pos_;
        return true;
      }
      return false;
    }
  }

  const std::string& s_;
  size_t pos_ = 0;
  std::set<std::string> paths_;
  std::map<std::string, std::string> scalars_;
};

TEST(JsonChecker, AcceptsValidAndRejectsInvalidJson) {
  const char* good[] = {"{}", "[]", "0", "-1.5e-3", "\"a\\u00e9\\n\"", R"({"a": [1, {"b": null}], "c": true})"};
  for (const char* g : good) EXPECT_TRUE(JsonChecker(g).parse()) << g;
  const char* bad[] = {"", "{", "{\"a\" 1}", "[1,]", "01", "1.", "nan", "\"tab\there\"", "{\"a\":1}x", "{'a': 1}"};
  for (const char* b : bad) EXPECT_FALSE(JsonChecker(b).parse()) << b;
}

// --- Helpers. ----------------------------------------------------------------------------------------------------

const bake::BakeOutput* find_output(const MaterialBakeResult& r, const std::string& name) {
  for (const auto& o : r.outputs)
    if (o.name == name) return &o;
  return nullptr;
}

brdf::ModelSpec ggx(double alpha) {
  brdf::ModelSpec s;
  s.model = brdf::Model::ggx;
  s.alpha_x = s.alpha_y = alpha;
  return s;
}

std::string error_of(const MaterialBakeInput& in) {
  try {
    bake_material(in);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

// --- Lambert: everything is exact. --------------------------------------------------------------------------------

TEST(MaterialBake, LambertTablesAreExactlyRho) {
  MaterialBakeInput in;
  in.model.albedo = Rgb{0.25, 0.5, 0.75};
  in.table_mu = 16;
  in.table_roughness = 4;
  const MaterialBakeResult r = bake_material(in);

  // Cosine sampling gives every sample the weight ρ, up to the rounding of f cos / pdf and of the means (1e-14).
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.average_albedo[c], in.model.albedo[c], 1e-14);
  EXPECT_NEAR(r.white_furnace.average.value.g, 1.0, 1e-14);

  const bake::BakeOutput* albedo = find_output(r, "albedo.exr");
  ASSERT_NE(albedo, nullptr);
  EXPECT_EQ(albedo->media_type, "image/x-exr");
  const image::FloatImage img = image::decode_exr(albedo->bytes);
  ASSERT_EQ(img.width, 16);
  ASSERT_EQ(img.height, 1);
  // Read by name: the meaning of a channel is its name (and its kiln:channel.NAME description), not its position.
  std::vector<std::string> names = img.channel_names;
  std::sort(names.begin(), names.end());
  ASSERT_EQ(names, (std::vector<std::string>{"B", "G", "R", "err.B", "err.G", "err.R", "white", "white_err"}));
  for (const std::string& n : names) EXPECT_EQ(img.metadata.count("kiln:channel." + n), 1u) << n;
  const int r_c = img.channel_index("R"), g_c = img.channel_index("G"), b_c = img.channel_index("B");
  const int white_c = img.channel_index("white");
  for (int x = 0; x < img.width; ++x) {
    // Stored as float: the double estimate is within 1e-14 of ρ, far inside half a float ulp of these ρ (exact
    // binary fractions), so the texel is exactly float(ρ).
    EXPECT_EQ(img.at(x, 0, r_c), 0.25f);
    EXPECT_EQ(img.at(x, 0, g_c), 0.5f);
    EXPECT_EQ(img.at(x, 0, b_c), 0.75f);
    EXPECT_EQ(img.at(x, 0, white_c), 1.0f);
    for (const char* e : {"err.R", "err.G", "err.B", "white_err"}) {
      EXPECT_LT(img.at(x, 0, img.channel_index(e)), 1e-7f) << "error of a zero-variance estimate";
    }
  }
  // A white Lambert's split sum: scale + bias = E = 1 exactly (each sample splits its weight 1 in two); rows equal.
  const image::FloatImage ss = image::decode_exr(find_output(r, "split_sum.exr")->bytes);
  ASSERT_EQ(ss.width, 16);
  ASSERT_EQ(ss.height, 4);
  const int scale_c = ss.channel_index("scale"), bias_c = ss.channel_index("bias");
  for (int y = 0; y < ss.height; ++y) {
    for (int x = 0; x < ss.width; ++x) {
      EXPECT_NEAR(ss.at(x, y, scale_c) + ss.at(x, y, bias_c), 1.0, 1e-6) << "float rounding of two numbers ≤ 1";
      EXPECT_EQ(ss.at(x, y, scale_c), ss.at(x, 0, scale_c));
      // The bake's own table, by name: scale is scale (the swap a positional reader made is caught here).
      EXPECT_EQ(ss.at(x, y, scale_c), static_cast<float>(r.split_sum.at_scale(y, x)));
      EXPECT_EQ(ss.at(x, y, bias_c), static_cast<float>(r.split_sum.at_bias(y, x)));
    }
  }
  EXPECT_TRUE(r.validation.energy.conserves_energy);
  EXPECT_NEAR(r.validation.energy.white_max_albedo, 1.0, 1e-14);
  EXPECT_EQ(r.validation.reciprocity.max_relative_difference, 0.0) << "a constant is exactly reciprocal";
  EXPECT_TRUE(r.validation.approximations.empty());
}

// --- GGX: target error reached, values agree with independent estimates. -----------------------------------------

// Tolerance: the bake and the reference are independent unbiased estimates, each with a standard error estimated
// from replicates. We allow 5 combined standard errors, taking the bake's as the larger of its estimate and the
// target (its estimate has few degrees of freedom and may come out low). Seeds are fixed, so this is deterministic;
// 5σ keeps it far from a coin flip if the seeds or the estimator change.
double allowed(double bake_se, double target, double ref_se) {
  const double b = std::max(bake_se, target);
  return 5.0 * std::sqrt(b * b + ref_se * ref_se);
}

TEST(MaterialBake, GgxReachesTargetErrorAndAgreesWithIndependentEstimates) {
  MaterialBakeInput in;
  in.model = ggx(0.4);
  in.model.fresnel = brdf::FresnelMode::schlick;
  in.model.f0 = Rgb{0.04, 0.3, 0.6};  // all below 0.669: dielectrics, so exact Fresnel applies
  in.table_mu = 8;
  in.table_roughness = 4;
  in.target_error = 1e-3;
  const MaterialBakeResult r = bake_material(in);
  RecordProperty("bake_seconds", std::to_string(r.seconds));
  RecordProperty("max_samples_per_entry", std::to_string(r.max_samples_per_entry));

  EXPECT_TRUE(r.target_reached);
  EXPECT_LE(r.max_error_estimate, 1e-3);
  for (const auto& e : r.albedo.e) EXPECT_LE(e.std_error.max(), 1e-3);
  for (const auto& e : r.white_furnace.e) EXPECT_LE(e.std_error.max(), 1e-3);
  for (size_t k = 0; k < r.split_sum.scale.size(); ++k) {
    EXPECT_LE(r.split_sum.scale_error[k], 1e-3);
    EXPECT_LE(r.split_sum.bias_error[k], 1e-3);
  }
  EXPECT_LE(r.albedo.average.std_error.max(), 1e-3);
  // The EXR carries the same errors.
  const image::FloatImage img = image::decode_exr(find_output(r, "albedo.exr")->bytes);
  for (int x = 0; x < img.width; ++x)
    for (const char* e : {"err.R", "err.G", "err.B", "white_err"}) EXPECT_LE(img.at(x, 0, img.channel_index(e)), 1e-3f);

  // Independent references: the library's estimators with other seeds and 2^18 samples (error ~2e-4).
  const auto bxdf = brdf::make_bxdf(in.model);
  const auto white = brdf::make_bxdf(brdf::without_fresnel(in.model));
  brdf::AlbedoOptions ref;
  ref.samples = 1 << 18;
  ref.seed = 987654321;
  for (int i = 0; i < in.table_mu; ++i) {
    const double mu = (i + 0.5) / in.table_mu;
    EXPECT_DOUBLE_EQ(r.albedo.mu[i], mu);
    const brdf::Estimate e = brdf::directional_albedo(*bxdf, mu, ref);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(r.albedo.e[i].value[c], e.value[c], allowed(r.albedo.e[i].std_error[c], 1e-3, e.std_error[c]))
          << "mu " << mu << " channel " << c;
      EXPECT_NEAR(img.at(i, 0, c), r.albedo.e[i].value[c], 1e-7) << "EXR holds the table (float rounding)";
    }
    const brdf::Estimate w = brdf::directional_albedo(*white, mu, ref);
    EXPECT_NEAR(r.white_furnace.e[i].value.g, w.value.g,
                allowed(r.white_furnace.e[i].std_error.g, 1e-3, w.std_error.g));
  }
  brdf::AlbedoOptions ref_ss;
  ref_ss.samples = 1 << 16;
  ref_ss.seed = 55;
  const brdf::SplitSumTable t = brdf::split_sum_table(in.model, in.table_mu, in.table_roughness, ref_ss);
  for (size_t k = 0; k < t.scale.size(); ++k) {
    EXPECT_NEAR(r.split_sum.scale[k], t.scale[k], allowed(r.split_sum.scale_error[k], 1e-3, t.scale_error[k])) << k;
    EXPECT_NEAR(r.split_sum.bias[k], t.bias[k], allowed(r.split_sum.bias_error[k], 1e-3, t.bias_error[k])) << k;
  }
  EXPECT_EQ(r.split_sum.roughness, t.roughness);
  brdf::AlbedoOptions ref_avg = ref;
  ref_avg.samples = 1 << 16;  // albedo_table estimates the average with 4× this
  const brdf::AlbedoTable avg = brdf::albedo_table(*bxdf, 1, ref_avg);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(r.average_albedo[c], avg.average.value[c],
                allowed(r.albedo.average.std_error[c], 1e-3, avg.average.std_error[c]));
  }

  // Validation: GGX is reciprocal; its Schlick Fresnel and separable masking are the approximations measured.
  EXPECT_LT(r.validation.reciprocity.max_relative_difference, 1e-12);
  EXPECT_TRUE(r.validation.energy.conserves_energy);
  ASSERT_EQ(r.validation.approximations.size(), 2u);
  EXPECT_NE(r.validation.approximations[0].name.find("fresnel"), std::string::npos);
  EXPECT_NE(r.validation.approximations[1].name.find("height-correlated"), std::string::npos);
  // Each reported difference, measured again at its μ with the library and other seeds: the largest channel of
  // |E_approx − E_exact|. Tolerance 5 combined standard errors (the reported one is already an upper bound).
  brdf::ModelSpec height_correlated = in.model;
  height_correlated.masking = brdf::Masking::height_correlated;
  const auto hc = brdf::make_bxdf(height_correlated);
  for (const auto& a : r.validation.approximations) {
    ASSERT_TRUE(std::isfinite(a.max_abs_difference));
    EXPECT_GT(a.max_abs_difference, 0.0) << a.name;
    EXPECT_LE(a.mean_abs_difference, a.max_abs_difference);
    const brdf::Estimate approx = brdf::directional_albedo(*bxdf, a.at_mu, ref);
    double expected = 0, se = 0;
    for (int c = 0; c < 3; ++c) {
      brdf::Estimate exact;
      if (a.name.find("fresnel") != std::string::npos) {
        brdf::ModelSpec s = in.model;
        s.fresnel = brdf::FresnelMode::exact;
        s.eta = (1 + std::sqrt(in.model.f0[c])) / (1 - std::sqrt(in.model.f0[c]));
        exact = brdf::directional_albedo(*brdf::make_bxdf(s), a.at_mu, ref);
      } else {
        exact = brdf::directional_albedo(*hc, a.at_mu, ref);
      }
      const double d = std::fabs(approx.value[c] - exact.value[c]);
      if (d > expected) {
        expected = d;
        se = std::hypot(approx.std_error[c], exact.std_error[c]);
      }
    }
    EXPECT_NEAR(a.max_abs_difference, expected, 5.0 * std::hypot(a.std_error, se)) << a.name;
    RecordProperty(a.name, std::to_string(a.max_abs_difference) + " at mu " + std::to_string(a.at_mu));
  }
}

TEST(MaterialBake, FixedSampleCountIsTakenForEveryEntryAndTheBakeIsReproducible) {
  MaterialBakeInput in;
  in.model = ggx(0.3);
  in.table_mu = 4;
  in.table_roughness = 3;
  in.samples = 2048;
  const MaterialBakeResult a = bake_material(in);
  // 2048 per entry is rounded up to 8 replicates of 16² strata.
  EXPECT_EQ(a.min_samples_per_entry, 2048u);
  EXPECT_EQ(a.max_samples_per_entry, 2048u);
  const MaterialBakeResult b = bake_material(in);
  EXPECT_EQ(find_output(a, "albedo.exr")->bytes, find_output(b, "albedo.exr")->bytes);
  EXPECT_EQ(find_output(a, "split_sum.exr")->bytes, find_output(b, "split_sum.exr")->bytes);
  in.seed = 2;
  const MaterialBakeResult c = bake_material(in);
  EXPECT_NE(find_output(a, "albedo.exr")->bytes, find_output(c, "albedo.exr")->bytes) << "the seed is used";
}

TEST(MaterialBake, TimeLimitStopsRefinementAndSaysSo) {
  MaterialBakeInput in;
  in.model = ggx(0.3);
  in.table_mu = 4;
  in.table_roughness = 2;
  in.target_error = 1e-7;          // unreachable: ~10^11 samples per entry
  in.samples = uint64_t{1} << 30;  // so the cap is not what stops it
  in.time_limit_seconds = 0.3;
  const MaterialBakeResult r = bake_material(in);
  EXPECT_FALSE(r.target_reached);
  bool said = false;
  for (const auto& p : r.plan) said = said || p.find("time limit reached") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_GT(r.max_error_estimate, 1e-7);
}

// --- Progress and cancel. ----------------------------------------------------------------------------------------

TEST(MaterialBake, ProgressIsMonotoneAndEndsAtOne) {
  MaterialBakeInput in;
  in.model = ggx(0.5);
  in.table_mu = 8;
  in.table_roughness = 4;
  in.target_error = 2e-3;
  std::vector<bake::BakeProgress> seen;
  bake::BakeControl control;
  control.progress = [&](const bake::BakeProgress& p) { seen.push_back(p); };  // calls are serialised by the bake
  bake_material(in, control);
  ASSERT_GE(seen.size(), 2u);
  for (size_t k = 1; k < seen.size(); ++k) {
    EXPECT_GE(seen[k].fraction, seen[k - 1].fraction);
    EXPECT_GE(seen[k].samples, seen[k - 1].samples);
  }
  for (const auto& p : seen) {
    EXPECT_GE(p.fraction, 0.0);
    EXPECT_LE(p.fraction, 1.0);
    EXPECT_TRUE(std::isfinite(p.error_estimate));
  }
  EXPECT_EQ(seen.back().fraction, 1.0);
  EXPECT_EQ(seen.back().stage, "done");
  for (size_t k = 0; k + 1 < seen.size(); ++k) EXPECT_LT(seen[k].fraction, 1.0) << "1 only at the end";
  EXPECT_GT(seen.back().samples, 0u);
}

TEST(MaterialBake, CancelFromTheProgressCallbackStopsPromptly) {
  MaterialBakeInput in;
  in.model = ggx(0.3);  // the default 32 × 32 table: about a thousand entries
  std::atomic<bool> cancel{false};
  int calls = 0, calls_after_cancel = 0;
  double last_fraction = 0;
  bake::BakeControl control;
  control.cancel = &cancel;
  control.progress = [&](const bake::BakeProgress& p) {
    ++calls;
    if (cancel) ++calls_after_cancel;
    last_fraction = p.fraction;
    cancel = true;  // after the first entry
  };
  EXPECT_THROW(bake_material(in, control), bake::BakeCancelled);
  EXPECT_GE(calls, 1);
  // Entries already running on the other threads may finish and report; no new one starts. With 2 cores a couple;
  // 16 leaves room for a machine with more.
  EXPECT_LE(calls_after_cancel, 16);
  EXPECT_LT(last_fraction, 0.1) << "the table was not finished";
}

TEST(MaterialBake, CancelBeforeStartThrowsAtOnce) {
  std::atomic<bool> cancel{true};
  bake::BakeControl control;
  control.cancel = &cancel;
  MaterialBakeInput in;
  EXPECT_THROW(bake_material(in, control), bake::BakeCancelled);
}

// --- Outputs and the report. -------------------------------------------------------------------------------------

TEST(MaterialBake, ReportJsonIsValidAndHasTheExpectedKeys) {
  MaterialBakeInput in;
  in.model = ggx(0.3);
  in.model.fresnel = brdf::FresnelMode::schlick;
  in.table_mu = 4;
  in.table_roughness = 2;
  in.samples = 1024;
  const MaterialBakeResult r = bake_material(in);
  ASSERT_EQ(r.outputs.size(), 4u);
  EXPECT_EQ(r.outputs[0].name, "albedo.exr");
  EXPECT_EQ(r.outputs[1].name, "split_sum.exr");
  EXPECT_EQ(r.outputs[2].name, "preview.png");
  EXPECT_EQ(r.outputs[3].name, "report.json");
  EXPECT_EQ(r.outputs[3].media_type, "application/json");
  JsonChecker json(r.outputs[3].bytes);
  ASSERT_TRUE(json.parse()) << "invalid JSON near byte " << json.error_at() << ":\n" << r.outputs[3].bytes;
  for (const char* key : {"baker",
                          "model.description",
                          "settings.table_mu",
                          "settings.target_error",
                          "average_albedo.value",
                          "average_albedo.std_error",
                          "validation.energy.max_albedo",
                          "validation.energy.max_albedo_mu",
                          "validation.energy.white_furnace_max_albedo",
                          "validation.energy.conserves_energy",
                          "validation.reciprocity.max_relative_difference",
                          "validation.reciprocity.pairs",
                          "validation.approximations[].name",
                          "validation.approximations[].max_abs_albedo_difference",
                          "cost.samples",
                          "cost.seconds",
                          "cost.max_error_estimate",
                          "cost.target_reached",
                          "outputs[].name",
                          "outputs[].bytes",
                          "outputs[].media_type",
                          "outputs[].color_space"}) {
    EXPECT_TRUE(json.paths().count(key)) << "report.json lacks " << key;
  }
  EXPECT_EQ(json.scalars().at("baker"), std::string("\"") + kMaterialBakerVersion + "\"");
  EXPECT_EQ(json.scalars().at("settings.table_mu"), "4");
  bool merl_skipped = false;
  for (const auto& p : r.plan) merl_skipped = merl_skipped || p == "merl skipped: not requested";
  EXPECT_TRUE(merl_skipped);
  EXPECT_NE(r.outputs[3].bytes.find("merl skipped: not requested"), std::string::npos);
}

TEST(MaterialBake, MerlOutputWhenAsked) {
  MaterialBakeInput in;
  in.model = ggx(0.3);
  in.table_mu = 2;
  in.table_roughness = 1;
  in.samples = 256;
  in.merl = true;
  const MaterialBakeResult r = bake_material(in);
  const bake::BakeOutput* m = find_output(r, "brdf.merl");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->bytes.size(), kMerlFileBytes);
  const MerlTable t = decode_merl(m->bytes);
  const auto bxdf = brdf::make_bxdf(in.model);
  const MerlDirections w = merl_directions(0.3, 0.4, 1.0);
  const Rgb f = bxdf->eval(w.wo, w.wi), g = lookup(t, w.wo, w.wi);
  // Away from the centre of its cell, so only within the cell's variation: 10% at α = 0.3.
  EXPECT_NEAR(g.g, f.g, 0.1 * f.g);
}

// --- Invalid input. ----------------------------------------------------------------------------------------------

TEST(MaterialBake, InvalidInputNamesTheField) {
  MaterialBakeInput in;
  in.table_mu = 0;
  EXPECT_EQ(error_of(in).rfind("table_mu: must be in [1, 1024], got 0", 0), 0u) << error_of(in);
  in.table_mu = 100000;
  EXPECT_EQ(error_of(in).rfind("table_mu:", 0), 0u) << error_of(in);
  EXPECT_NE(error_of(in).find("100000"), std::string::npos);
  in = {};
  in.table_roughness = -3;
  EXPECT_EQ(error_of(in).rfind("table_roughness:", 0), 0u) << error_of(in);
  in = {};
  in.model = ggx(-0.2);
  EXPECT_EQ(error_of(in).rfind("model.alpha_x: must be in (0, 1], got -0.2", 0), 0u) << error_of(in);
  in = {};
  in.model.albedo = Rgb{0.5, 1.5, 0.5};
  EXPECT_EQ(error_of(in).rfind("model.albedo:", 0), 0u) << error_of(in);
  in = {};
  in.target_error = std::nan("");
  EXPECT_EQ(error_of(in).rfind("target_error:", 0), 0u) << error_of(in);
  in = {};
  in.target_error = -1e-3;
  EXPECT_EQ(error_of(in).rfind("target_error:", 0), 0u) << error_of(in);
  in = {};
  in.time_limit_seconds = -1;
  EXPECT_EQ(error_of(in).rfind("time_limit_seconds:", 0), 0u) << error_of(in);
  in = {};
  in.samples = uint64_t{1} << 40;
  EXPECT_EQ(error_of(in).rfind("samples:", 0), 0u) << error_of(in);
  in = {};
  in.material = brdf::MaterialSpec{};
  in.material->diffuse.albedo = Rgb{2.0};
  EXPECT_EQ(error_of(in).rfind("material.diffuse.albedo:", 0), 0u) << error_of(in);
  // validate() says the same without baking.
  in = {};
  in.table_mu = 0;
  ASSERT_TRUE(validate(in).has_value());
  EXPECT_EQ(std::string(validate(in)->what()).rfind("table_mu:", 0), 0u);
  EXPECT_FALSE(validate(MaterialBakeInput{}).has_value());
}

}  // namespace
}  // namespace kiln::material
