// The `kiln` command line without a daemon: flags to job specs, job files and their errors (with line numbers),
// the progress lines, report.json, exit statuses; and the whole binary against a small fake kilnd in this file
// (the real daemon is exercised by the integration tests).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "client/cli/args.h"
#include "client/cli/bake_flags.h"
#include "client/cli/env_flags.h"
#include "client/cli/format.h"
#include "client/cli/job_file.h"
#include "client/cli/lightmap_flags.h"
#include "client/cli/probes_flags.h"
#include "client/cli/progress.h"
#include "client/cli/report.h"
#include "daemon/translate.h"
#include "proto/digest.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"
#include "tests/support/run_command.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;
using google::protobuf::util::MessageDifferencer;

const fs::path kExamples = fs::path(KILN_SOURCE_DIR) / "client" / "examples";

std::vector<std::string> words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

v1::JobSpec from_flags(const std::string& s) { return material_spec_from_flags(words(s)); }

// The UsageError `f` throws, or "(no error)".
template <typename F>
std::string usage_error_of(F f) {
  try {
    f();
  } catch (const UsageError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string usage_error(const std::string& s) {
  return usage_error_of([&] { from_flags(s); });
}

v1::JobSpec from_text(const std::string& text) {
  v1::JobSpec spec;
  parse_job_text(text, "job.textproto", spec);
  return spec;
}

std::string text_error(const std::string& text) {
  return usage_error_of([&] { from_text(text); });
}

// The daemon's translation layer accepts the spec (the same checks a real submit meets).
::testing::AssertionResult daemon_accepts(const v1::JobSpec& spec) {
  try {
    daemon::translate(spec);
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << e.what() << "\n" << spec.DebugString();
  }
}

// ---- Flags to job specs -------------------------------------------------------------------------------------

TEST(KilnCliBakeFlags, TheIssuesExampleBecomesAGgxSpec) {
  const v1::JobSpec s = from_flags("--model ggx --alpha 0.3 --fresnel schlick --f0 0.04 --out out/x");
  ASSERT_TRUE(s.has_material());
  ASSERT_TRUE(s.material().has_ggx());
  const v1::Microfacet& m = s.material().ggx();
  EXPECT_TRUE(m.has_alpha());
  EXPECT_EQ(m.alpha(), 0.3);
  EXPECT_FALSE(m.has_alpha_x());
  EXPECT_EQ(m.fresnel(), v1::FRESNEL_SCHLICK);
  EXPECT_EQ(m.f0().r(), 0.04);
  EXPECT_EQ(m.f0().g(), 0.04);
  EXPECT_EQ(m.f0().b(), 0.04);
  EXPECT_FALSE(m.has_eta());
  EXPECT_EQ(m.distribution(), v1::DISTRIBUTION_DEFAULT);
  EXPECT_FALSE(s.material().merl());
  EXPECT_FALSE(s.has_quality());  // nothing asked: the server's defaults
  EXPECT_EQ(s.name(), "ggx alpha=0.3 fresnel=schlick f0=0.04");
  EXPECT_TRUE(daemon_accepts(s));
}

TEST(KilnCliBakeFlags, EveryMicrofacetFlagMaps) {
  const v1::JobSpec s = from_flags(
      "--model cook-torrance --alpha-x 0.2 --alpha-y 0.6 --fresnel exact --eta 1.33 --distribution schlick-beckmann "
      "--masking height-correlated --normalization pi");
  const v1::Microfacet& m = s.material().cook_torrance();
  EXPECT_FALSE(m.has_alpha());
  EXPECT_EQ(m.alpha_x(), 0.2);
  EXPECT_EQ(m.alpha_y(), 0.6);
  EXPECT_EQ(m.fresnel(), v1::FRESNEL_EXACT);
  EXPECT_EQ(m.eta(), 1.33);
  EXPECT_EQ(m.distribution(), v1::DISTRIBUTION_SCHLICK_BECKMANN);
  EXPECT_EQ(m.masking(), v1::MASKING_HEIGHT_CORRELATED);
  EXPECT_EQ(m.normalization(), v1::NORMALIZATION_PI);
  EXPECT_TRUE(daemon_accepts(s));

  // Cook-Torrance's own Fresnel is exact: --eta needs no --fresnel there.
  EXPECT_EQ(from_flags("--model cook-torrance --eta 2").material().cook_torrance().eta(), 2.0);
  // Underscores (job-file spelling) are accepted for names.
  EXPECT_EQ(from_flags("--model beckmann --masking v_groove").material().beckmann().masking(), v1::MASKING_V_GROOVE);
  EXPECT_EQ(from_flags("--model ggx --normalization 4").material().ggx().normalization(), v1::NORMALIZATION_FOUR);
  EXPECT_EQ(from_flags("--model ggx --distribution beckmann").material().ggx().distribution(),
            v1::DISTRIBUTION_BECKMANN);
  EXPECT_EQ(from_flags("--model ggx --fresnel none").material().ggx().fresnel(), v1::FRESNEL_NONE);
}

TEST(KilnCliBakeFlags, DiffuseAndSchlickModelsMap) {
  const v1::JobSpec on = from_flags("--model oren-nayar --albedo 0.8,0.5,0.3 --sigma 0.5 --interreflection on");
  ASSERT_TRUE(on.material().has_oren_nayar());
  EXPECT_EQ(on.material().oren_nayar().albedo().g(), 0.5);
  EXPECT_EQ(on.material().oren_nayar().sigma(), 0.5);
  EXPECT_TRUE(on.material().oren_nayar().interreflection());
  EXPECT_TRUE(daemon_accepts(on));

  const v1::JobSpec simple = from_flags("--model oren_nayar_simple --sigma 0.2 --interreflection off");
  ASSERT_TRUE(simple.material().has_oren_nayar_simple());
  EXPECT_FALSE(simple.material().oren_nayar_simple().interreflection());
  EXPECT_TRUE(daemon_accepts(simple));

  const v1::JobSpec lambert = from_flags("--model lambert");
  EXPECT_TRUE(lambert.material().has_lambert());
  EXPECT_FALSE(lambert.material().lambert().has_albedo());
  EXPECT_EQ(from_flags("--model lambert --albedo 0.25").material().lambert().albedo().b(), 0.25);

  // kiln-brdf's --albedo is the Schlick layer's reflection factor; so is kiln's.
  const v1::JobSpec schlick = from_flags("--model schlick --albedo 0.9 --r 0.2 --p 0.3");
  EXPECT_EQ(schlick.material().schlick().c().r(), 0.9);
  EXPECT_EQ(schlick.material().schlick().r(), 0.2);
  EXPECT_EQ(schlick.material().schlick().p(), 0.3);
  EXPECT_TRUE(daemon_accepts(schlick));

  const v1::JobSpec dbl =
      from_flags("--model schlick-double --c 0.1,0.2,0.3 --r 0.05 --bottom-c 0.7 --bottom-r 1 --bottom-p 0.5");
  const v1::SchlickDouble& d = dbl.material().schlick_double();
  EXPECT_EQ(d.top().c().b(), 0.3);
  EXPECT_EQ(d.top().r(), 0.05);
  EXPECT_FALSE(d.top().has_p());
  EXPECT_EQ(d.bottom().c().g(), 0.7);
  EXPECT_EQ(d.bottom().r(), 1.0);
  EXPECT_EQ(d.bottom().p(), 0.5);
  EXPECT_TRUE(daemon_accepts(dbl));
}

TEST(KilnCliBakeFlags, QualityTablesAndEffectsMap) {
  const v1::JobSpec s = from_flags(
      "--model ggx --samples 1e5 --target-error 0.002 --time-limit 30 --seed 7 --table-mu 64 --table-roughness 16 "
      "--merl --force merl=off --name my-ggx --priority 5 --idempotency-key ci-42 --server unix:/x --out d");
  EXPECT_EQ(s.quality().samples(), 100000u);
  EXPECT_EQ(s.quality().target_error(), 0.002);
  EXPECT_EQ(s.quality().time_limit_seconds(), 30.0);
  EXPECT_EQ(s.quality().seed(), 7u);
  EXPECT_EQ(s.material().table_mu(), 64u);
  EXPECT_EQ(s.material().table_roughness(), 16u);
  EXPECT_TRUE(s.material().merl());
  ASSERT_EQ(s.force_effects().count("merl"), 1u);
  EXPECT_FALSE(s.force_effects().at("merl"));
  EXPECT_EQ(s.name(), "my-ggx");
  EXPECT_TRUE(daemon_accepts(s));
  // --flag=value works like --flag value.
  EXPECT_EQ(from_flags("--model=ggx --alpha=0.5").material().ggx().alpha(), 0.5);
}

TEST(KilnCliBakeFlags, BadFlagsGetOneLineNamingTheFlag) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--alpha 0.3", "--model: missing; expected one of lambert"},
      {"--model phong", "--model: expected one of lambert, oren-nayar"},
      {"--model ggx --alpha", "--alpha: missing value"},
      {"--model ggx --alpha --out x", "--alpha: missing value"},
      {"--model ggx --alpha abc", "--alpha: expected a number, got 'abc'"},
      {"--model ggx --alpha nan", "--alpha: must be a finite number, got 'nan'"},
      {"--model ggx --alpha inf", "--alpha: must be a finite number"},
      {"--model ggx --alpha 0", "--alpha: must be in (0, 1], got 0"},
      {"--model ggx --alpha -0.2", "--alpha: must be in (0, 1], got -0.2"},
      {"--model ggx --alpha 1.5", "--alpha: must be in (0, 1], got 1.5"},
      {"--model ggx --alpha 0.3 --alpha 0.4", "--alpha: given twice"},
      {"--model ggx --alpha 0.3 --alpha-x 0.2 --alpha-y 0.2", "--alpha: give either --alpha or --alpha-x"},
      {"--model ggx --alpha-x 0.2", "--alpha-y: missing; --alpha-x and --alpha-y go together"},
      {"--model ggx --f0 0.04", "--f0: only --fresnel schlick uses it"},
      {"--model ggx --fresnel exact --f0 0.04", "add --fresnel schlick"},
      {"--model ggx --eta 1.5", "--eta: only exact Fresnel uses it"},
      {"--model ggx --fresnel schlick --f0 0.1,0.2", "--f0: expected one value or three (R,G,B), got '0.1,0.2'"},
      {"--model ggx --fresnel schlick --f0 0.1,0.2,", "--f0: expected a number, got ''"},
      {"--model ggx --fresnel schlick --f0 1.2", "--f0: must be in [0, 1], got 1.2"},
      {"--model ggx --fresnel fast", "--fresnel: expected one of none, schlick, exact, got 'fast'"},
      {"--model ggx --eta 11 --fresnel exact", "--eta: must be in [0.1, 10], got 11"},
      {"--model ggx --masking smith", "--masking: expected one of separable, height-correlated"},
      {"--model ggx --normalization 2", "--normalization: expected one of 4, pi, got '2'"},
      {"--model ggx --sigma 0.3", "--sigma: --model ggx has no such parameter (--sigma is for oren-nayar"},
      {"--model ggx --albedo 0.5", "--albedo: --model ggx has no such parameter"},
      {"--model lambert --alpha 0.3", "--alpha: --model lambert has no such parameter"},
      {"--model schlick --bottom-r 0.3", "--bottom-r: --model schlick has no such parameter"},
      {"--model schlick --albedo 0.5 --c 0.5", "--albedo: give --albedo or --c, not both"},
      {"--model schlick --r 2", "--r: must be in [0, 1], got 2"},
      {"--model oren-nayar --sigma 2", "--sigma: must be in [0, 1.5707963267948966], got 2"},
      {"--model oren-nayar --interreflection yes", "--interreflection: expected on or off, got 'yes'"},
      {"--model oren-nayar-simple --interreflection on", "--interreflection: the two-bounce term belongs to the full"},
      {"--model ggx --samples 0", "--samples: must be a whole number in [1, 16777216], got 0"},
      {"--model ggx --samples 2.5", "--samples: must be a whole number"},
      {"--model ggx --samples 1e9", "--samples: must be a whole number in [1, 16777216], got 1e9"},
      {"--model ggx --target-error 0", "--target-error: must be in (0, 1], got 0"},
      {"--model ggx --time-limit 100000", "--time-limit: must be in (0, 86400], got 100000"},
      {"--model ggx --table-mu 1", "--table-mu: must be a whole number in [2, 1024], got 1"},
      {"--model ggx --table-roughness 2048", "--table-roughness: must be a whole number in [2, 1024]"},
      {"--model ggx --force merl", "--force: expected EFFECT=on or EFFECT=off, got 'merl'"},
      {"--model ggx --force merl=on --force merl=off", "--force: effect 'merl' given twice"},
      {"--model ggx --merl=yes", "--merl: takes no value, got 'yes'"},
      {"--model ggx --colour red", "unknown option --colour for `kiln bake material`"},
      {"--model ggx --name " + std::string(300, 'n'), "--name: at most 256 bytes, got 300"},
      {"--diffuse lambert", "--specular: missing; a two-lobe material needs both"},
      {"--model ggx --specular ggx --diffuse lambert", "--model: give either --model or --diffuse and --specular"},
      {"--diffuse lambert --specular ggx --alpha 0.3", "--alpha: a two-lobe material takes its lobes' parameters"},
      {"--diffuse lambert --specular ggx --diffuse-alpha 0.3",
       "--diffuse-alpha: --diffuse lambert has no such parameter"},
      {"--diffuse lambert --specular ggx --specular-f0 0.04", "--specular-f0: only --specular-fresnel schlick uses it"},
      {"--diffuse lambert --specular ggx --specular-alpha 2", "--specular-alpha: must be in (0, 1], got 2"},
      {"--diffuse lambert --specular ggx --specular-weight 0.3", "--specular-weight: applies to --combine weights"},
      {"--diffuse lambert --specular ggx --combine mixed", "--combine: expected one of layered, weights"},
      {"--diffuse phong --specular ggx", "--diffuse: expected one of lambert"},
  };
  for (const auto& [args, expected] : cases) {
    const std::string error = usage_error(args);
    EXPECT_NE(error.find(expected), std::string::npos) << "kiln bake material " << args << "\n  gave: " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
}

TEST(KilnCliBakeFlags, TwoLobeMaterialsTakeTheLobeFlags) {
  const v1::JobSpec s = from_flags(
      "--diffuse oren-nayar --diffuse-albedo 0.5,0.4,0.3 --diffuse-sigma 0.2 --specular ggx --specular-alpha 0.2 "
      "--specular-fresnel schlick --specular-f0 0.04 --combine weights --specular-weight 0.3");
  ASSERT_TRUE(s.material().has_layered());
  const v1::Layered& l = s.material().layered();
  EXPECT_EQ(l.diffuse().oren_nayar().albedo().g(), 0.4);
  EXPECT_EQ(l.diffuse().oren_nayar().sigma(), 0.2);
  EXPECT_EQ(l.specular().ggx().alpha(), 0.2);
  EXPECT_EQ(l.specular().ggx().fresnel(), v1::FRESNEL_SCHLICK);
  EXPECT_EQ(l.specular().ggx().f0().r(), 0.04);
  EXPECT_EQ(l.combine(), v1::COMBINE_WEIGHTS);
  EXPECT_EQ(l.specular_weight(), 0.3);
  EXPECT_EQ(s.name().rfind("weights oren-nayar+ggx", 0), 0u) << s.name();
  EXPECT_TRUE(daemon_accepts(s));
  // Layered by default, and a Schlick lobe takes --specular-albedo as its C like --albedo does for --model.
  const v1::JobSpec d = from_flags("--diffuse lambert --specular schlick --specular-albedo 0.9 --specular-r 0.3");
  EXPECT_EQ(d.material().layered().combine(), v1::COMBINE_DEFAULT);
  EXPECT_EQ(d.material().layered().specular().schlick().c().r(), 0.9);
  EXPECT_EQ(d.material().layered().specular().schlick().r(), 0.3);
}

TEST(KilnCliBakeFlags, ServerFieldsMapBackToFlags) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"job.material.ggx.alpha", "--alpha"},
      {"job.material.cook_torrance.alpha_x", "--alpha-x"},
      {"job.material.beckmann.alpha_y", "--alpha-y"},
      {"job.material.ggx.f0.g", "--f0"},
      {"job.material.ggx.f0", "--f0"},
      {"job.material.ggx.eta", "--eta"},
      {"job.material.ggx.masking", "--masking"},
      {"job.material.lambert.albedo.r", "--albedo"},
      {"job.material.oren_nayar.sigma", "--sigma"},
      {"job.material.oren_nayar_simple.interreflection", "--interreflection"},
      {"job.material.schlick.r", "--r"},  // roughness, not red
      {"job.material.schlick.c.r", "--c"},
      {"job.material.schlick_double.top.p", "--p"},
      {"job.material.schlick_double.bottom.c.b", "--bottom-c"},
      {"job.material.schlick_double.bottom.r", "--bottom-r"},
      {"job.material.table_mu", "--table-mu"},
      {"job.material.table_roughness", "--table-roughness"},
      {"job.material", "--model"},
      {"job.quality.samples", "--samples"},
      {"job.quality.target_error", "--target-error"},
      {"job.quality.time_limit_seconds", "--time-limit"},
      {"job.quality.seed", "--seed"},
      {"job.force_effects[merl]", "--force"},
      {"job.name", "--name"},
      {"job.material.layered.specular.ggx.alpha", "--specular-alpha"},
      {"job.material.layered.specular.ggx.f0.g", "--specular-f0"},
      {"job.material.layered.diffuse.oren_nayar.sigma", "--diffuse-sigma"},
      {"job.material.layered.diffuse.lambert.albedo.r", "--diffuse-albedo"},
      {"job.material.layered.specular.schlick_double.bottom.r", "--specular-bottom-r"},
      {"job.material.layered.specular.schlick.c", "--specular-c"},
      {"job.material.layered.specular", "--specular"},
      {"job.material.layered.combine", "--combine"},
      {"job.material.layered.specular_weight", "--specular-weight"},
      {"job", ""},
      {"digests[3].sha256", ""},
  };
  for (const auto& [field, flag] : cases) EXPECT_EQ(flag_for_field(field), flag) << field;
}

// ---- `kiln bake env` -----------------------------------------------------------------------------------------

EnvironmentBake env_from(const std::string& s) { return environment_bake_from_flags(words("env " + s)); }

std::string env_usage_error(const std::string& s) {
  return usage_error_of([&] { env_from(s); });
}

TEST(KilnCliBakeEnv, EveryFlagMaps) {
  const EnvironmentBake b = env_from(
      "sky.exr --color-space srgb_texture --rotation -90 --intensity 2.5 --lobe cook-torrance --size 64 --levels 3 "
      "--irradiance-size 16 --dfg-size 32 --dfg-samples 64 --samples 256 --target-error 0.02 --seed 7 --no-preview "
      "--force sun_light=off --out out/sky");
  EXPECT_EQ(b.files, std::vector<std::string>{"sky.exr"});
  const v1::EnvironmentJob& e = b.spec.environment();
  EXPECT_TRUE(e.has_image());
  EXPECT_EQ(e.color_space(), "srgb_texture");
  EXPECT_EQ(e.rotation_degrees(), -90);
  EXPECT_EQ(e.intensity(), 2.5);
  EXPECT_EQ(e.lobe(), v1::ENVIRONMENT_LOBE_COOK_TORRANCE);
  EXPECT_EQ(e.size(), 64u);
  EXPECT_EQ(e.levels(), 3u);
  EXPECT_EQ(e.irradiance_size(), 16u);
  EXPECT_EQ(e.dfg_size(), 32u);
  EXPECT_EQ(e.dfg_samples(), 64u);
  EXPECT_TRUE(e.has_preview());
  EXPECT_FALSE(e.preview());
  EXPECT_EQ(b.spec.quality().samples(), 256u);
  EXPECT_EQ(b.spec.quality().target_error(), 0.02);
  EXPECT_EQ(b.spec.quality().seed(), 7u);
  EXPECT_FALSE(b.spec.force_effects().at("sun_light"));
  EXPECT_EQ(b.spec.name().rfind("environment sky.exr color-space=srgb_texture", 0), 0u) << b.spec.name();

  // The uploaded digests go where the server looks for them; the translation layer then accepts the job.
  EnvironmentBake with_digest = b;
  v1::Digest d;
  d.set_sha256(proto::sha256_hex("sky"));
  d.set_size(3);
  set_input_digests(with_digest, {d});
  EXPECT_EQ(with_digest.spec.environment().image().sha256(), d.sha256());
  EXPECT_TRUE(daemon_accepts(with_digest.spec));

  EnvironmentBake faces = env_from("--faces px.exr nx.exr py.exr ny.exr pz.exr nz.exr --wait");
  EXPECT_EQ(faces.files.size(), 6u);
  EXPECT_EQ(faces.files[3], "ny.exr");
  set_input_digests(faces, std::vector<v1::Digest>(6, d));
  EXPECT_EQ(faces.spec.environment().faces().digests_size(), 6);
  EXPECT_TRUE(daemon_accepts(faces.spec));

  const EnvironmentBake constant = env_from("--constant 0.5");
  EXPECT_TRUE(constant.files.empty());
  EXPECT_EQ(constant.spec.environment().constant().g(), 0.5);
  EXPECT_FALSE(constant.spec.has_quality());  // nothing asked: the server's defaults
  EXPECT_TRUE(daemon_accepts(constant.spec));
  EXPECT_EQ(env_from("--constant 1,2,3 --lobe cook_torrance").spec.environment().lobe(),
            v1::ENVIRONMENT_LOBE_COOK_TORRANCE);  // the job-file spelling too
}

TEST(KilnCliBakeEnv, BadFlagsGetOneLineNamingTheFlag) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "missing environment"},
      {"a.exr b.exr", "unexpected argument 'b.exr'"},
      {"--constant 1 sky.exr", "--constant: give one environment"},
      {"--constant 1 --faces a b c d e f", "--constant: give one environment"},
      {"--faces a b c", "--faces: expected six files"},
      {"--constant 1,2", "--constant: expected one value or three"},
      {"--constant -1", "--constant: must be in [0, 1e+06], got -1"},
      {"--constant 1 --intensity 2", "--intensity: applies to an image"},
      {"--constant 1 --rotation 2", "--rotation: applies to an image"},
      {"sky.exr --size 100", "--size: must be a power of two"},
      {"sky.exr --size 4096", "--size: must be a whole number in [4, 2048]"},
      {"sky.exr --rotation 400", "--rotation: must be in [-360, 360]"},
      {"sky.exr --intensity 0", "--intensity: must be in (0, 1e+06]"},
      {"sky.exr --lobe phong", "--lobe: expected one of ggx, beckmann, cook-torrance, schlick, got 'phong'"},
      {"sky.exr --samples 2", "--samples: must be a whole number in [4, 65536]"},
      {"sky.exr --target-error 0", "--target-error: must be in [1e-04, 1], got 0"},
      {"sky.exr --force sun", "--force: expected EFFECT=on or EFFECT=off"},
      {"sky.exr --alpha 0.3", "unknown option --alpha for `kiln bake env`"},
  };
  for (const auto& [flags, message] : cases) {
    EXPECT_NE(env_usage_error(flags).find(message), std::string::npos) << flags << " -> " << env_usage_error(flags);
  }
}

TEST(KilnCliBakeEnv, DfgMaskingFlag) {
  EXPECT_EQ(env_from("sky.exr --dfg-masking separable").spec.environment().dfg_masking(), v1::MASKING_SEPARABLE);
  EXPECT_EQ(env_from("sky.exr --dfg-masking height-correlated").spec.environment().dfg_masking(),
            v1::MASKING_HEIGHT_CORRELATED);
  EXPECT_EQ(env_from("sky.exr").spec.environment().dfg_masking(), v1::MASKING_DEFAULT);  // the server's default
  EXPECT_EQ(env_usage_error("sky.exr --dfg-masking v-groove"),
            "--dfg-masking: expected separable or height-correlated, got 'v-groove'");
}

TEST(KilnCliBakeEnv, ServerFieldsMapBackToFlags) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"job.environment.size", "--size"},
      {"job.environment.levels", "--levels"},
      {"job.environment.rotation_degrees", "--rotation"},
      {"job.environment.color_space", "--color-space"},
      {"job.environment.constant.g", "--constant"},
      {"job.environment.faces.digests[2].sha256", "--faces"},
      {"job.environment.dfg_samples", "--dfg-samples"},
      {"job.environment.dfg_masking", "--dfg-masking"},
      {"job.environment.image", ""},  // the command's argument: `kiln bake env` names the file itself
      {"job.environment", ""},
  };
  for (const auto& [field, flag] : cases) EXPECT_EQ(flag_for_field(field), flag) << field;
}

// ---- Job files -------------------------------------------------------------------------------------------------

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The flags a job file's comments give as its equivalent: the first "kiln bake material ..." or "kiln bake env ..."
// (continued with "\" on "#" lines), the job type's word first.
std::string flags_in_comment(const std::string& text) {
  std::istringstream in(text);
  std::string flags;
  bool continuing = false;
  for (std::string line; std::getline(in, line);) {
    const auto at = line.find("kiln bake ");
    if (!continuing && at == std::string::npos) continue;
    std::string part = continuing ? line.substr(line.find_first_not_of("# ")) : line.substr(at + 10);
    continuing = !part.empty() && part.back() == '\\';
    if (continuing) part.pop_back();
    flags += part + " ";
    if (!continuing) break;
  }
  return flags;
}

TEST(KilnCliJobFiles, ExamplesParseMatchTheirFlagsAndPassTheDaemonsChecks) {
  int count = 0, environment = 0;
  for (const auto& entry : fs::directory_iterator(kExamples)) {
    if (entry.path().extension() != ".textproto") continue;
    ++count;
    SCOPED_TRACE(entry.path().filename().string());
    v1::JobSpec spec;
    std::string text;
    ASSERT_NO_THROW(read_job_file(entry.path().string(), spec, text));
    EXPECT_FALSE(spec.name().empty());
    EXPECT_TRUE(daemon_accepts(spec));
    // The command in the file's comment asks for the same bake (names aside, which are not part of the job).
    const std::vector<std::string> flags = words(flags_in_comment(text));
    ASSERT_FALSE(flags.empty()) << "no `kiln bake material|env ... --out DIR` line in the comments";
    v1::JobSpec from_comment;
    if (flags[0] == "env") {
      ++environment;
      const EnvironmentBake bake = environment_bake_from_flags(flags);
      EXPECT_TRUE(bake.files.empty()) << "job files name no local files";
      from_comment = bake.spec;
    } else {
      ASSERT_EQ(flags[0], "material");
      from_comment = material_spec_from_flags(std::vector<std::string>(flags.begin() + 1, flags.end()));
    }
    from_comment.clear_name();
    spec.clear_name();
    EXPECT_TRUE(MessageDifferencer::Equals(spec, from_comment)) << "file:\n"
                                                                << spec.DebugString() << "flags:\n"
                                                                << from_comment.DebugString();
  }
  // A GGX dielectric, an Oren-Nayar clay, a Cook-Torrance glass with MERL, a Schlick brushed metal, a layered
  // plastic with MERL; a constant environment.
  EXPECT_EQ(count, 6);
  EXPECT_EQ(environment, 1);
}

TEST(KilnCliJobFiles, ParseErrorsGiveFileLineAndColumn) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"name: \"x\"\nmaterial {\n  gxx { alpha: 0.3 }\n}\n", "job.textproto:3:3: "},
      {"material {\n  ggx {\n    alpha: \"high\"\n  }\n}\n", "job.textproto:3:12: "},
      {"material {\n  ggx {\n    fresnel: FRESNEL_SCHLIK\n  }\n}\n", "job.textproto:3:14: "},
      {"material {\n  ggx { alpha: 0.3 }\n", "job.textproto:3:1: "},  // unclosed brace: the error is at the end
      {"material { ggx { } oren_nayar { } }\n", "job.textproto:1:"},  // two models of one oneof
      {"# only a comment\n", "job.textproto: no job in the file"},
      {"", "job.textproto: no job in the file"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string error = text_error(text);
    EXPECT_EQ(error.rfind(expected, 0), 0u) << text << "\n  gave: " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  EXPECT_NE(text_error("material {\n  gxx { }\n}\n").find("gxx"), std::string::npos);
}

TEST(KilnCliJobFiles, UnreadableAndOversizedFilesAreUsageErrors) {
  v1::JobSpec spec;
  std::string text;
  try {
    read_job_file("/nonexistent/job.textproto", spec, text);
    FAIL() << "no error";
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "cannot read job file /nonexistent/job.textproto: No such file or directory");
  }
  const fs::path big = fs::temp_directory_path() / ("kiln_cli_big_" + std::to_string(::getpid()) + ".textproto");
  {
    std::ofstream out(big);
    out << std::string((4 << 20) + 10, ' ');
  }
  try {
    read_job_file(big.string(), spec, text);
    FAIL() << "no error";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("larger than 4 MiB"), std::string::npos) << e.what();
  }
  fs::remove(big);
}

TEST(KilnCliJobFiles, ServerFieldPathsAreLocatedInTheText) {
  const std::string text =
      "name: \"x\"\n"                                // 1
      "material {\n"                                 // 2
      "  ggx {\n"                                    // 3
      "    alpha: -0.2\n"                            // 4
      "    f0 { r: 2 g: 0 }\n"                       // 5
      "  }\n"                                        // 6
      "  table_mu: 1\n"                              // 7
      "}\n"                                          // 8
      "quality { samples: 0 }\n"                     // 9
      "force_effects { key: \"x\" value: true }\n";  // 10
  EXPECT_EQ(locate_field(text, "job.material.ggx.alpha"), "4:5");
  EXPECT_EQ(locate_field(text, "job.material.ggx.f0.r"), "5:10");
  EXPECT_EQ(locate_field(text, "job.material.ggx.f0.b"), "5:5");  // b not written: f0 is where it comes from
  EXPECT_EQ(locate_field(text, "job.material.ggx.eta"), "3:3");
  EXPECT_EQ(locate_field(text, "job.material.table_mu"), "7:3");
  EXPECT_EQ(locate_field(text, "job.quality.samples"), "9:11");
  EXPECT_EQ(locate_field(text, "job.force_effects[x]"), "10:1");
  EXPECT_EQ(locate_field(text, "job.name"), "1:1");
  EXPECT_EQ(locate_field(text, "job.material.oren_nayar.sigma"), "2:1");
  EXPECT_EQ(locate_field(text, "job.nonsense"), std::nullopt);
  EXPECT_EQ(locate_field(text, "digests[0]"), std::nullopt);
  EXPECT_EQ(locate_field("not a job {", "job.material"), std::nullopt);
  // An index on a singular field (a malformed path from a server) stops the walk at the enclosing field; it used to
  // abort the client inside protobuf (found by tests/fuzz/job_text_fuzz.cpp).
  EXPECT_EQ(locate_field(text, "job.material[0].ggx.alpha"), std::nullopt);
  EXPECT_EQ(locate_field(text, "job.material.ggx[2].alpha"), "2:1");
}

// ---- Progress, formats, reports ---------------------------------------------------------------------------------

v1::JobEvent event(v1::JobState state, double fraction, bool final = false) {
  v1::JobEvent e;
  e.set_job_id("j1");
  e.set_state(state);
  e.set_fraction(fraction);
  e.set_eta_seconds(fraction < 1 ? 12.5 : 0);
  e.set_elapsed_seconds(3.25);
  e.set_samples(1234567);
  e.set_error_estimate(0.00031);
  e.set_final(final);
  return e;
}

int lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

TEST(KilnCliProgress, PlainLinesComeEveryTenPercentAtMostOnceASecond) {
  std::ostringstream out;
  {
    ProgressPrinter p(out, false);
    p.update(event(v1::JOB_STATE_QUEUED, 0), 0.0);
    // 1000 events in 100 s: a line per 10 % (every 10 s here).
    for (int i = 0; i < 1000; ++i) p.update(event(v1::JOB_STATE_RUNNING, i / 1000.0), 0.1 * i);
    p.update(event(v1::JOB_STATE_SUCCEEDED, 1, true), 100.0);
  }
  // queued, running at 0 %, then 10 % ... 90 %, succeeded.
  EXPECT_EQ(lines(out.str()), 12) << out.str();
  EXPECT_EQ(out.str().find('\r'), std::string::npos);
  EXPECT_NE(out.str().find("job j1: running 50%  ETA 12.5 s  error 3.1e-04  1.23 M samples\n"), std::string::npos)
      << out.str();
  EXPECT_NE(out.str().find("job j1: succeeded after 3.25 s, 1.23 M samples, error 3.1e-04\n"), std::string::npos);

  // Fast progress: at most one line a second, but the changes of state always show.
  std::ostringstream fast;
  {
    ProgressPrinter p(fast, false);
    for (int i = 0; i <= 100; ++i) p.update(event(v1::JOB_STATE_RUNNING, i / 100.0), 0.01 * i);
    p.update(event(v1::JOB_STATE_SUCCEEDED, 1, true), 1.01);
  }
  EXPECT_LE(lines(fast.str()), 3) << fast.str();

  // Slow progress: a line at least every 30 s, so a CI log shows the bake is alive.
  std::ostringstream slow;
  {
    ProgressPrinter p(slow, false);
    for (int i = 0; i <= 120; ++i) p.update(event(v1::JOB_STATE_RUNNING, i / 10000.0), i);
  }
  EXPECT_EQ(lines(slow.str()), 5) << slow.str();  // at 0, 30, 60, 90, 120 s
}

TEST(KilnCliProgress, TerminalRedrawsOneLineWithBarEtaAndError) {
  std::ostringstream out;
  {
    ProgressPrinter p(out, true, 200);
    p.update(event(v1::JOB_STATE_RUNNING, 0.5), 0.0);
    p.update(event(v1::JOB_STATE_RUNNING, 0.51), 0.01);  // too soon: not redrawn
    p.update(event(v1::JOB_STATE_RUNNING, 0.52), 0.5);
    p.update(event(v1::JOB_STATE_SUCCEEDED, 1, true), 0.6);
  }
  const std::string s = out.str();
  EXPECT_EQ(std::count(s.begin(), s.end(), '\r'), 3) << s;
  EXPECT_EQ(lines(s), 1) << s;  // one line, ended when the job ended
  EXPECT_NE(s.find("[############............] running 50%  ETA 12.5 s  error 3.1e-04"), std::string::npos) << s;
  EXPECT_NE(s.find("[########################] succeeded"), std::string::npos) << s;

  // Cut to the terminal's width, so that \r can redraw it.
  std::ostringstream narrow;
  {
    ProgressPrinter p(narrow, true, 40);
    p.update(event(v1::JOB_STATE_RUNNING, 0.5), 0.0);
  }
  const std::string first = narrow.str().substr(1, narrow.str().find("\x1b[K") - 1);
  EXPECT_EQ(first.size(), 39u) << narrow.str();
}

TEST(KilnCliProgress, ServerMessagesCannotMoveTheCursor) {
  v1::JobEvent e = event(v1::JOB_STATE_FAILED, 0.3, true);
  e.set_message("bad\r\x1b[2Jthing\n");
  const std::string s = ProgressPrinter::describe(e);
  EXPECT_EQ(s.find_first_of("\r\n\x1b"), std::string::npos) << s;
  EXPECT_EQ(s, "failed: bad\\r\\x1b[2Jthing\\n");  // escaped as in kilnd's log: nothing is lost
}

TEST(KilnCliFormat, NumbersForPeople) {
  EXPECT_EQ(format_duration(0.421), "0.42 s");
  EXPECT_EQ(format_duration(12.34), "12.3 s");
  EXPECT_EQ(format_duration(245), "4 min 05 s");
  EXPECT_EQ(format_duration(7380), "2 h 03 min");
  EXPECT_EQ(format_duration(-1), "?");
  EXPECT_EQ(format_count(950), "950");
  EXPECT_EQ(format_count(12345), "12.3 k");
  EXPECT_EQ(format_count(4194304), "4.19 M");
  EXPECT_EQ(format_bytes(812), "812 B");
  EXPECT_EQ(format_bytes(34992012), "33.4 MiB");
  EXPECT_EQ(format_error(0.00031), "3.1e-04");
  EXPECT_EQ(format_error(0.02), "0.02");
  EXPECT_EQ(format_error(0), "0");
  EXPECT_EQ(format_error(-1), "unknown");
  EXPECT_EQ(format_number(0.3), "0.3");
}

v1::JobResult sample_result() {
  v1::JobResult r;
  r.set_job_id("j1");
  r.set_name("ggx \"quoted\"\n");
  r.set_state(v1::JOB_STATE_SUCCEEDED);
  auto* o = r.add_outputs();
  o->set_name("albedo.exr");
  o->set_media_type("image/x-exr");
  o->mutable_digest()->set_sha256(std::string(64, 'a'));
  o->mutable_digest()->set_size(1234);
  auto* b = r.mutable_report();
  b->set_samples(4194304);
  b->set_seconds(12.25);
  b->set_error_estimate(0.0003);
  b->set_cache_hit(true);
  auto* d = b->add_plan();
  d->set_effect("merl");
  d->set_reason("not asked for");
  return r;
}

TEST(KilnCliReport, AssembledJsonCarriesCostPlanAndDigests) {
  const std::string j = result_json(sample_result());
  EXPECT_NE(j.find("\"name\": \"ggx \\\"quoted\\\"\\n\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"samples\": 4194304"), std::string::npos) << j;
  EXPECT_NE(j.find("\"seconds\": 12.25"), std::string::npos) << j;
  EXPECT_NE(j.find("\"cache_hit\": true"), std::string::npos) << j;
  EXPECT_NE(j.find("{\"effect\": \"merl\", \"enabled\": false, \"forced\": false, \"reason\": \"not asked for\"}"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"sha256\": \"" + std::string(64, 'a') + "\", \"size\": 1234"), std::string::npos) << j;
  EXPECT_EQ(json_string(std::string("a\x01"
                                    "b",
                                    3)),
            "\"a\\u0001b\"");
}

TEST(KilnCliReport, ReportJsonIsTheServersOwnWhenItSendsOne) {
  v1::JobResult r = sample_result();
  EXPECT_EQ(report_json_for(r), result_json(r));  // no report from the server: assembled
  r.mutable_report()->set_json("{\"whole\": true}");
  EXPECT_EQ(report_json_for(r), "{\"whole\": true}\n");
  r.add_outputs()->set_name("report.json");  // the bake wrote its own: that one is saved as it is
  EXPECT_EQ(report_json_for(r), std::nullopt);
}

TEST(KilnCliReport, OnlyPlainFileNamesAreWritten) {
  EXPECT_TRUE(is_plain_file_name("albedo.exr"));
  EXPECT_TRUE(is_plain_file_name("brdf.merl"));
  for (const char* bad : {"", ".", "..", "../x", "a/b", "/etc/passwd", "a\nb"}) {
    EXPECT_FALSE(is_plain_file_name(bad)) << bad;
  }
  EXPECT_FALSE(is_plain_file_name(std::string(256, 'x')));
}

TEST(KilnCliReport, CostLineSaysCacheHitOrNot) {
  v1::JobResult r = sample_result();
  EXPECT_EQ(cost_line(r, false).rfind("4.19 M samples, 12.2 s of baking, error estimate 3.0e-04, cache miss", 0), 0u)
      << cost_line(r, false);
  EXPECT_NE(cost_line(r, true).find("cache hit"), std::string::npos);
}

// ---- The binary ----------------------------------------------------------------------------------------------

struct Outcome {
  int status = -1;
  std::string out, err;
};

// A folder for this test process, removed when it exits.
const fs::path& scratch() {
  struct Scratch {
    fs::path dir = fs::temp_directory_path() / ("kiln_cli_test_" + std::to_string(::getpid()));
    Scratch() { fs::create_directories(dir); }
    ~Scratch() {
      std::error_code ignored;
      fs::remove_all(dir, ignored);
    }
  };
  static const Scratch scratch;
  return scratch.dir;
}

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs kiln with `args` (each quoted), no KILN_* variables from the test's environment.
Outcome kiln(const std::vector<std::string>& args, const std::string& env = "") {
  const fs::path err_file = scratch() / "stderr.txt";
  std::string cmd = "env -u KILN_SERVER -u KILN_TOKEN -u KILN_TOKEN_FILE " + env + " " + quote(KILN_CLI_BIN);
  for (const auto& a : args) cmd += " " + quote(a);
  cmd += " 2>" + quote(err_file.string()) + " </dev/null";
  const test::CommandResult run = test::run_command(cmd);
  Outcome r;
  r.status = run.status;
  r.out = run.output;
  r.err = read(err_file);
  return r;
}

fs::path write_job(const std::string& name, const std::string& text) {
  const fs::path p = scratch() / name;
  std::ofstream(p) << text;
  return p;
}

// A port on which nothing listens: bound, then closed.
std::string closed_port_address() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
}

TEST(KilnCliBinary, HelpAndUsageErrors) {
  const Outcome help = kiln({"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("usage: kiln"), std::string::npos);
  EXPECT_NE(help.out.find("exit status"), std::string::npos);
  for (const char* cmd : {"submit", "bake", "watch", "result", "fetch", "cancel", "status", "jobs"}) {
    const Outcome r = kiln({cmd, "--help"});
    EXPECT_EQ(r.status, 0) << cmd;
    EXPECT_NE(r.out.find("usage: kiln " + std::string(cmd)), std::string::npos) << cmd << ": " << r.out;
    EXPECT_EQ(kiln({"help", cmd}).out, r.out) << cmd;
  }
  // --help wins over the rest of a half-typed line.
  EXPECT_EQ(kiln({"bake", "material", "--alpha", "--help"}).status, 0);

  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{}, "kiln: missing command: expected one of submit, bake,"},
      {{"bake"}, "kiln: missing job type: `kiln bake material ...`"},
      {{"bake", "lightmap"}, "kiln: missing scene: `kiln bake lightmap SCENE.gltf --out DIR`"},
      {{"bake", "texture"}, "kiln: unknown job type 'texture'"},
      {{"bake", "lightmap", "s.gltf", "--resolution", "3"},
       "kiln: --resolution: must be a whole number in [4, 8192], got 3"},
      {{"bake", "lightmap", "s.gltf", "--env", "a.exr", "--env-constant", "1"},
       "kiln: --env-constant: give one environment"},
      {{"bake", "lightmap", "s.gltf", "--env-rotation", "10"}, "kiln: --env-rotation: turns an --env image"},
      {{"frobnicate"}, "kiln: unknown command 'frobnicate'"},
      {{"--colour", "status"}, "kiln: unknown option --colour before the command"},
      {{"status", "--limit", "3"}, "kiln: unknown option --limit for `kiln status`"},
      {{"watch"}, "kiln: missing job id: `kiln watch ID`"},
      {{"watch", "a", "b"}, "kiln: unexpected argument 'b'"},
      {{"fetch", "j1"}, "kiln: --out: missing; fetch writes the outputs into a folder"},
      {{"bake", "material", "--model", "ggx"}, "kiln: --out: missing; bake writes its outputs into a folder"},
      {{"bake", "material", "--model", "ggx", "--alpha", "2", "--out", "x"}, "kiln: --alpha: must be in (0, 1], got 2"},
      {{"submit"}, "kiln: missing job file"},
      {{"submit", "/nonexistent.textproto"}, "kiln: cannot read job file /nonexistent.textproto: No such file"},
      {{"submit", "x.textproto", "--priority", "101"}, "kiln: --priority: must be a whole number in [-100, 100]"},
      {{"jobs", "--state", "done"}, "kiln: --state: expected one of queued, running, succeeded, failed, cancelled"},
      {{"jobs", "--limit", "0"}, "kiln: --limit: must be a whole number in [1, 1000], got 0"},
      {{"status", "--server", "localhost"}, "kiln: --server: server address \"localhost\": expected HOST:PORT"},
      {{"status", "--token-file", "/nonexistent/token"}, "kiln: --token-file /nonexistent/token: cannot read"},
      {{"status", "--tls-ca", "/nonexistent/ca.pem"}, "kiln: TLS CA file /nonexistent/ca.pem: cannot read it"},
      {{"--tls-ca=/nonexistent/ca.pem", "status"}, "kiln: TLS CA file /nonexistent/ca.pem: cannot read it"},
      {{"status", "--tls-cert", "client.pem", "--tls-key", "client.key"}, "kiln: --tls-cert needs --tls-ca"},
      {{"status", "--tls-ca", "ca.pem", "--tls-key", "client.key"},
       "kiln: TLS client key client.key: needs its certificate (from --tls-ca, --tls-key)"},
  };
  for (const auto& [args, expected] : cases) {
    const Outcome r = kiln(args);
    std::string line;
    for (const auto& a : args) line += a + " ";
    EXPECT_EQ(r.status, 2) << line << "\n" << r.err;
    EXPECT_EQ(r.err.rfind(expected, 0), 0u) << line << "\n  gave: " << r.err;
    EXPECT_EQ(lines(r.err), 1) << line << "\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << line << "\n" << r.out;
  }
}

TEST(KilnCliBinary, JobFileErrorsNameTheLine) {
  const fs::path job = write_job("typo.textproto", "# a job\nmaterial {\n  ggx { alpah: 0.3 }\n}\n");
  const Outcome r = kiln({"submit", job.string(), "--server", closed_port_address()});
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.err.rfind("kiln: " + job.string() + ":3:9: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("alpah"), std::string::npos) << r.err;
}

TEST(KilnCliBinary, NoServerIsExitThree) {
  const fs::path job = write_job("ok.textproto", "material { ggx { alpha: 0.3 } }\n");
  const std::string address = closed_port_address();
  for (const auto& args : std::vector<std::vector<std::string>>{{"status", "--server", address},
                                                                {"submit", job.string(), "--server", address},
                                                                {"watch", "j1", "--server", address}}) {
    const Outcome r = kiln(args);
    EXPECT_EQ(r.status, 3) << args[0] << ": " << r.err;
    EXPECT_EQ(r.err.rfind("kiln: cannot talk to kilnd at " + address + ": ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("Is kilnd running there?"), std::string::npos) << r.err;
  }
  // KILN_SERVER chooses the server when --server does not.
  const Outcome env = kiln({"status"}, "KILN_SERVER=" + address);
  EXPECT_NE(env.err.find("kilnd at " + address), std::string::npos) << env.err;
}

// ---- Against a fake kilnd ------------------------------------------------------------------------------------

// Serves one connection at a time on a loopback port, as kilnd would for one job "j1": hello (with a token
// check), submit, watch (a list of events, or running events every 20 ms until a cancel), cancel, result, fetch,
// status and list.
class FakeKilnd {
 public:
  std::string token = "secret-token";
  std::vector<v1::JobEvent> events;  // sent in answer to a watch; the last one should be final
  bool stream_until_cancel = false;
  bool drop_first_watch = false;  // close the connection after the first event of the first watch
  std::optional<v1::Error> submit_error, result_error;
  bool cache_hit = false;
  v1::JobResult result;
  std::map<std::string, std::string> served;  // sha256 -> the bytes Fetch answers with

  FakeKilnd() {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listen_fd_, 8) != 0) {
      throw std::runtime_error("fake kilnd: bind");
    }
    socklen_t len = sizeof a;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    address_ = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
  }
  ~FakeKilnd() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    ::close(listen_fd_);
  }
  // Configure first, then start.
  void start() {
    thread_ = std::thread([this] { run(); });
  }
  const std::string& address() const { return address_; }

  // Adds an output with these bytes; `served` may be changed afterwards to serve other bytes.
  void add_output(const std::string& name, const std::string& bytes, const std::string& description = "") {
    auto* o = result.add_outputs();
    o->set_name(name);
    o->set_media_type("application/octet-stream");
    o->set_description(description);
    o->mutable_digest()->set_sha256(proto::sha256_hex(bytes));
    o->mutable_digest()->set_size(bytes.size());
    served[o->digest().sha256()] = bytes;
  }

  std::vector<v1::Request> requests() {
    std::lock_guard lock(mutex_);
    return requests_;
  }
  bool saw(v1::Request::BodyCase body) {
    for (const auto& r : requests()) {
      if (r.body_case() == body) return true;
    }
    return false;
  }

 private:
  static void send(int fd, const v1::Response& r) {
    const std::string frame = proto::encode_frame(r);
    std::string_view rest = frame;
    while (!rest.empty()) {
      const ssize_t n = ::send(fd, rest.data(), rest.size(), MSG_NOSIGNAL);
      if (n <= 0) return;
      rest.remove_prefix(static_cast<std::size_t>(n));
    }
  }
  static void send_error(int fd, std::uint64_t id, const v1::Error& e) {
    v1::Response r;
    r.set_id(id);
    *r.mutable_error() = e;
    send(fd, r);
  }
  void run() {
    while (!stop_) {
      pollfd p{listen_fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd < 0) continue;
      serve(fd);
      ::close(fd);
    }
  }
  void serve(int fd) {
    proto::FrameDecoder decoder;
    std::vector<char> buffer(64 << 10);
    std::uint64_t watch_id = 0;
    auto last_event = std::chrono::steady_clock::now();
    while (!stop_) {
      if (watch_id && stream_until_cancel) {
        const auto t = std::chrono::steady_clock::now();
        if (cancelled_ || t - last_event > std::chrono::milliseconds(20)) {
          v1::Response r;
          r.set_id(watch_id);
          v1::JobEvent& e = *r.mutable_event();
          e.set_job_id("j1");
          e.set_state(cancelled_ ? v1::JOB_STATE_CANCELLED : v1::JOB_STATE_RUNNING);
          e.set_fraction(0.25);
          e.set_eta_seconds(-1);
          e.set_error_estimate(-1);
          e.set_final(cancelled_);
          send(fd, r);
          last_event = t;
          if (cancelled_) watch_id = 0;
        }
      }
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 5) <= 0) continue;
      const ssize_t n = ::read(fd, buffer.data(), buffer.size());
      if (n <= 0) return;
      decoder.feed(std::string_view(buffer.data(), static_cast<std::size_t>(n)));
      std::string_view payload;
      proto::FrameDecoder::Status status;
      while ((status = decoder.next(payload)) == proto::FrameDecoder::Status::frame) {
        v1::Request request;
        if (!proto::parse_frame(payload, request)) return;
        {
          std::lock_guard lock(mutex_);
          requests_.push_back(request);
        }
        if (!handle(fd, request, watch_id)) return;
      }
      if (status == proto::FrameDecoder::Status::error) return;
    }
  }
  bool handle(int fd, const v1::Request& q, std::uint64_t& watch_id) {
    v1::Response r;
    r.set_id(q.id());
    v1::Error not_found;
    not_found.set_code(v1::Error::NOT_FOUND);
    not_found.set_message("no such job");
    not_found.set_field("job_id");
    switch (q.body_case()) {
      case v1::Request::kHello: {
        if (q.hello().token() != token) {
          v1::Error e;
          e.set_code(v1::Error::UNAUTHENTICATED);
          e.set_message("wrong or missing token");
          send_error(fd, q.id(), e);
          return false;
        }
        auto* h = r.mutable_hello();
        h->set_protocol_version(proto::kProtocolVersion);
        h->set_server_version("fake-kilnd 0");
        h->mutable_limits()->set_max_chunk_bytes(1000);  // several chunks per output
        h->mutable_limits()->set_heartbeat_seconds(5);
        h->add_job_types("material");
        break;
      }
      case v1::Request::kSubmit:
        if (submit_error) {
          send_error(fd, q.id(), *submit_error);
          return true;
        }
        r.mutable_submit()->set_job_id("j1");
        r.mutable_submit()->set_cache_hit(cache_hit);
        r.mutable_submit()->set_state(cache_hit ? v1::JOB_STATE_SUCCEEDED : v1::JOB_STATE_QUEUED);
        break;
      case v1::Request::kWatch:
        if (q.watch().job_id() != "j1") {
          send_error(fd, q.id(), not_found);
          return true;
        }
        if (stream_until_cancel) {
          watch_id = q.id();
          return true;
        }
        if (drop_first_watch && !dropped_) {
          dropped_ = true;
          *r.mutable_event() = events.front();
          send(fd, r);
          return false;
        }
        for (const auto& e : events) {
          *r.mutable_event() = e;
          send(fd, r);
        }
        return true;
      case v1::Request::kCancel:
        cancelled_ = true;
        r.mutable_cancel()->set_state(v1::JOB_STATE_CANCELLED);
        break;
      case v1::Request::kGetResult:
        if (q.get_result().job_id() != "j1") {
          send_error(fd, q.id(), not_found);
          return true;
        }
        if (result_error) {
          send_error(fd, q.id(), *result_error);
          return true;
        }
        *r.mutable_result() = result;
        break;
      case v1::Request::kFetch: {
        const auto& f = q.fetch();
        auto it = served.find(f.digest().sha256());
        if (it == served.end()) {
          v1::Error e;
          e.set_code(v1::Error::NOT_FOUND);
          e.set_message("no such blob");
          send_error(fd, q.id(), e);
          return true;
        }
        const std::string& bytes = it->second;
        const std::size_t offset = std::min<std::size_t>(f.offset(), bytes.size());
        const std::size_t n = std::min<std::size_t>(f.length() ? f.length() : 1000, bytes.size() - offset);
        r.mutable_fetch()->set_offset(f.offset());
        r.mutable_fetch()->set_data(bytes.substr(offset, n));
        r.mutable_fetch()->set_eof(offset + n >= bytes.size());
        break;
      }
      case v1::Request::kStatus: {
        auto* s = r.mutable_status();
        s->set_server_version("fake-kilnd 0");
        s->set_uptime_seconds(3725);
        s->set_queued(2);
        s->set_running(1);
        s->set_workers(1);
        s->set_cache_hits(7);
        s->set_store_bytes(1 << 20);
        break;
      }
      case v1::Request::kListJobs: {
        auto* j = r.mutable_jobs()->add_jobs();
        j->set_job_id("j1");
        j->set_name("ggx alpha=0.3");
        j->set_type("material");
        j->set_state(v1::JOB_STATE_SUCCEEDED);
        j->set_seconds(1.5);
        j->set_cache_hit(true);
        break;
      }
      default:
        return false;
    }
    send(fd, r);
    return true;
  }

  int listen_fd_ = -1;
  std::string address_;
  std::atomic<bool> stop_{false}, cancelled_{false}, dropped_{false};
  std::thread thread_;
  std::mutex mutex_;
  std::vector<v1::Request> requests_;
};

// A fake with one successful job: queued, running, succeeded; two outputs.
void succeed(FakeKilnd& k) {
  k.events = {event(v1::JOB_STATE_QUEUED, 0), event(v1::JOB_STATE_RUNNING, 0.5),
              event(v1::JOB_STATE_SUCCEEDED, 1, true)};
  k.result = sample_result();
  k.result.clear_outputs();
  k.result.set_name("ggx");
  k.result.mutable_report()->set_cache_hit(false);
  std::string big(5000, '\0');
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 7);
  k.add_output("albedo.exr", big, "directional albedo");
  k.add_output("split_sum.exr", "split sum bytes", "split-sum table");
}

std::vector<std::string> with_server(const FakeKilnd& k, std::vector<std::string> args) {
  args.insert(args.end(), {"--server", k.address()});
  return args;
}
const char* const kToken = "KILN_TOKEN=secret-token";

TEST(KilnCliBinary, SubmitWaitOutWritesVerifiedOutputsAndReport) {
  FakeKilnd k;
  succeed(k);
  k.start();
  const fs::path job = write_job("ggx.textproto", "material { ggx { alpha: 0.3 } }\n");
  const fs::path out = scratch() / "out-submit";
  const Outcome r = kiln(
      with_server(k, {"submit", job.string(), "--out", out.string(), "--priority", "7", "--idempotency-key", "ci-1"}),
      kToken);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read(out / "albedo.exr"), k.served[k.result.outputs(0).digest().sha256()]);
  EXPECT_EQ(read(out / "split_sum.exr"), "split sum bytes");
  EXPECT_EQ(read(out / "report.json"), result_json(k.result));  // no report from the server: assembled
  for (const auto& e : fs::directory_iterator(out)) {
    EXPECT_EQ(e.path().filename().string().find(".kiln-part"), std::string::npos) << e.path();
  }
  // Where the outputs went and what the bake cost, on stdout; progress lines on stderr.
  EXPECT_NE(r.out.find("job j1 succeeded: ggx"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("cost: 4.19 M samples, 12.2 s of baking, error estimate 3.0e-04, cache miss"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("outputs in " + out.string() + "/:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("report.json"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("job j1: running 50%"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("job j1: succeeded"), std::string::npos) << r.err;
  // The submit carried the file's spec, the priority and the key.
  for (const auto& q : k.requests()) {
    if (!q.has_submit()) continue;
    EXPECT_EQ(q.submit().priority(), 7);
    EXPECT_EQ(q.submit().idempotency_key(), "ci-1");
    EXPECT_EQ(q.submit().job().material().ggx().alpha(), 0.3);
  }
}

TEST(KilnCliBinary, SubmitWithoutWaitPrintsTheJobId) {
  FakeKilnd k;
  k.start();
  const fs::path job = write_job("ggx2.textproto", "material { ggx { alpha: 0.3 } }\n");
  const Outcome r = kiln(with_server(k, {"submit", job.string()}), kToken);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "j1\n");
  EXPECT_NE(r.err.find("kiln watch j1"), std::string::npos) << r.err;
  EXPECT_FALSE(k.saw(v1::Request::kWatch));
}

TEST(KilnCliBinary, BakeSendsTheFlagsSpecAndUsesTheServersReport) {
  FakeKilnd k;
  succeed(k);
  k.cache_hit = true;
  k.result.mutable_report()->set_json("{\"from\": \"the server\"}");
  k.start();
  const fs::path out = scratch() / "out-bake";
  const std::vector<std::string> flags = {"--model", "ggx", "--alpha", "0.3", "--fresnel", "schlick", "--f0", "0.04"};
  std::vector<std::string> args = {"bake", "material"};
  args.insert(args.end(), flags.begin(), flags.end());
  args.insert(args.end(), {"--out", out.string()});
  const Outcome r = kiln(with_server(k, args), kToken);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read(out / "report.json"), "{\"from\": \"the server\"}\n");
  EXPECT_NE(r.out.find("cache hit"), std::string::npos) << r.out;
  bool submitted = false;
  for (const auto& q : k.requests()) {
    if (!q.has_submit()) continue;
    submitted = true;
    EXPECT_TRUE(MessageDifferencer::Equals(q.submit().job(), material_spec_from_flags(flags)))
        << q.submit().job().DebugString();
  }
  EXPECT_TRUE(submitted);
}

TEST(KilnCliBinary, FailedJobIsExitOneWithTheReason) {
  FakeKilnd k;
  v1::JobEvent failed = event(v1::JOB_STATE_FAILED, 0.3, true);
  failed.set_message("the bake ran out of memory");
  k.events = {event(v1::JOB_STATE_RUNNING, 0.3), failed};
  k.start();
  const fs::path out = scratch() / "out-failed";
  const Outcome r = kiln(with_server(k, {"bake", "material", "--model", "lambert", "--out", out.string()}), kToken);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("kiln: job j1 failed: the bake ran out of memory\n"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_empty(out));
  EXPECT_FALSE(k.saw(v1::Request::kFetch));

  // watch says the same.
  const Outcome w = kiln(with_server(k, {"watch", "j1"}), kToken);
  EXPECT_EQ(w.status, 1) << w.err;
}

TEST(KilnCliBinary, RefusedFieldsPointAtTheFileLineOrTheFlag) {
  FakeKilnd k;
  v1::Error e;
  e.set_code(v1::Error::INVALID_ARGUMENT);
  e.set_message("must be in (0, 1], got -0.2");
  e.set_field("job.material.ggx.alpha");
  k.submit_error = e;
  k.start();
  const fs::path job = write_job("neg.textproto", "material {\n  ggx {\n    alpha: -0.2\n  }\n}\n");
  const Outcome r = kiln(with_server(k, {"submit", job.string(), "--wait"}), kToken);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(r.err, "kiln: " + job.string() +
                       ":3:5: the server refused the job: job.material.ggx.alpha: must be in (0, 1], got -0.2\n");

  // The flag check would refuse -0.2 already; a value the client lets through gets the server's word, by flag.
  const Outcome b = kiln(with_server(k, {"bake", "material", "--model", "ggx", "--alpha", "0.2", "--out",
                                         (scratch() / "out-refused").string()}),
                         kToken);
  EXPECT_EQ(b.status, 2) << b.err;
  EXPECT_EQ(b.err, "kiln: --alpha: the server refused the job: job.material.ggx.alpha: must be in (0, 1], got -0.2\n");
}

// A limit one field exceeds (kilnd's memory limit) is a refusal naming the flag, not a full queue to wait for.
TEST(KilnCliBinary, AFieldOverAServerLimitIsNamedNotQueuedFor) {
  FakeKilnd k;
  v1::Error e;
  e.set_code(v1::Error::RESOURCE_EXHAUSTED);
  e.set_message(
      "the job would need about 1.9 GiB of memory, more than kilnd's memory limit of 1.5 GiB "
      "(--memory-limit): lower this field, or bake in several jobs");
  e.set_field("job.material.table_mu");
  k.submit_error = e;
  k.start();
  const Outcome r = kiln(with_server(k, {"bake", "material", "--model", "ggx", "--alpha", "0.2", "--table-mu", "64",
                                         "--out", (scratch() / "out-too-big").string()}),
                         kToken);
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_NE(r.err.find("refused the job: --table-mu: the job would need about 1.9 GiB"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("try again when its queue has room"), std::string::npos) << r.err;
  // Without a field it is the queue's limit, which waiting does help.
  FakeKilnd full;
  e.set_message("the queue holds 10000 jobs, its limit; submit again later");
  e.clear_field();
  full.submit_error = e;
  full.start();
  const Outcome q = kiln(with_server(full, {"bake", "material", "--model", "ggx", "--alpha", "0.2", "--out",
                                            (scratch() / "out-queue-full").string()}),
                         kToken);
  EXPECT_NE(q.err.find("cannot take the job now: the queue holds"), std::string::npos) << q.err;
}

TEST(KilnCliBinary, BytesThatFailVerificationAreNotKept) {
  FakeKilnd k;
  succeed(k);
  std::string& bytes = k.served[k.result.outputs(1).digest().sha256()];
  bytes[0] ^= 1;
  k.start();
  const fs::path out = scratch() / "out-corrupt";
  const Outcome r = kiln(with_server(k, {"fetch", "j1", "--out", out.string()}), kToken);
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_NE(r.err.find("kiln: the bytes of split_sum.exr of job j1 did not match their digest"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out / "split_sum.exr"));
  EXPECT_FALSE(fs::exists(out / ".split_sum.exr.kiln-part"));
  EXPECT_FALSE(fs::exists(out / "report.json"));
}

TEST(KilnCliBinary, OutputNamesCannotLeaveTheFolder) {
  FakeKilnd k;
  succeed(k);
  k.add_output("../escaped.txt", "x");
  k.start();
  const fs::path out = scratch() / "out-escape" / "inner";
  const Outcome r = kiln(with_server(k, {"fetch", "j1", "--out", out.string()}), kToken);
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_NE(r.err.find("which is not a plain file name; nothing was written"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out.parent_path() / "escaped.txt"));
  EXPECT_TRUE(fs::is_empty(out));
}

TEST(KilnCliBinary, TokensComeFromTheFlagOrTheEnvironment) {
  FakeKilnd k;
  k.start();
  const Outcome none = kiln(with_server(k, {"status"}));
  EXPECT_EQ(none.status, 3);
  EXPECT_NE(none.err.find("refused this client: wrong or missing token; no token was given: pass --token-file"),
            std::string::npos)
      << none.err;
  const Outcome wrong = kiln(with_server(k, {"status"}), "KILN_TOKEN=nope");
  EXPECT_EQ(wrong.status, 3);
  EXPECT_NE(wrong.err.find("check the token"), std::string::npos) << wrong.err;

  const fs::path token = scratch() / "token";
  std::ofstream(token) << "# kilnd token\n\n  secret-token  \n";
  const Outcome file = kiln(with_server(k, {"status", "--token-file", token.string()}));
  EXPECT_EQ(file.status, 0) << file.err;
  const Outcome env_file = kiln(with_server(k, {"status"}), "KILN_TOKEN_FILE=" + token.string());
  EXPECT_EQ(env_file.status, 0) << env_file.err;
  EXPECT_NE(file.out.find("kilnd at " + k.address() + ": fake-kilnd 0, protocol 1, up 1 h 02 min"), std::string::npos)
      << file.out;
  EXPECT_NE(file.out.find("jobs: 2 queued, 1 running, 0 completed, 0 failed, 7 cache hits"), std::string::npos)
      << file.out;
}

TEST(KilnCliBinary, ResultJobsCancelAndUnknownIds) {
  FakeKilnd k;
  succeed(k);
  k.start();
  const Outcome result = kiln(with_server(k, {"result", "j1"}), kToken);
  EXPECT_EQ(result.status, 0) << result.err;
  EXPECT_NE(result.out.find("sha256 " + k.result.outputs(0).digest().sha256()), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("merl: off, not asked for"), std::string::npos) << result.out;
  const Outcome json = kiln(with_server(k, {"result", "j1", "--json"}), kToken);
  EXPECT_EQ(json.out, result_json(k.result));

  const Outcome jobs = kiln(with_server(k, {"jobs", "--limit", "5"}), kToken);
  EXPECT_EQ(jobs.status, 0) << jobs.err;
  EXPECT_NE(jobs.out.find("j1  succeeded material"), std::string::npos) << jobs.out;
  EXPECT_NE(jobs.out.find("hit   ggx alpha=0.3"), std::string::npos) << jobs.out;

  const Outcome cancel = kiln(with_server(k, {"cancel", "j1"}), kToken);
  EXPECT_EQ(cancel.status, 0) << cancel.err;
  EXPECT_EQ(cancel.out, "job j1 cancelled\n");

  for (const char* cmd : {"watch", "result"}) {
    const Outcome unknown = kiln(with_server(k, {cmd, "nope"}), kToken);
    EXPECT_EQ(unknown.status, 2) << cmd << ": " << unknown.err;
    EXPECT_NE(unknown.err.find("has no job 'nope'"), std::string::npos) << unknown.err;
  }
}

TEST(KilnCliBinary, ResultOfAnUnfinishedJobIsExitOne) {
  FakeKilnd k;
  v1::Error e;
  e.set_code(v1::Error::FAILED_PRECONDITION);
  e.set_message("job j1 is running");
  k.result_error = e;
  k.start();
  const Outcome r = kiln(with_server(k, {"result", "j1"}), kToken);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(r.err, "kiln: job j1 has not finished (job j1 is running); `kiln watch j1` waits for it\n");
}

TEST(KilnCliBinary, WatchReattachesAfterABrokenConnection) {
  FakeKilnd k;
  succeed(k);
  k.drop_first_watch = true;
  k.start();
  const Outcome r = kiln(with_server(k, {"watch", "j1"}), kToken);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("kiln: lost the connection: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("watching job j1); trying again in 1 s"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("job j1: succeeded"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("job j1 succeeded: ggx"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("kiln fetch j1 --out DIR"), std::string::npos) << r.out;
  int watches = 0;
  for (const auto& q : k.requests()) watches += q.has_watch();
  EXPECT_EQ(watches, 2);
}

TEST(KilnCliBinary, CtrlCDuringBakeCancelsTheJob) {
  FakeKilnd k;
  k.stream_until_cancel = true;
  k.start();
  const fs::path out = scratch() / "out-interrupted";
  const fs::path err_file = scratch() / "interrupted.err";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::setenv("KILN_TOKEN", "secret-token", 1);
    std::freopen(err_file.c_str(), "w", stderr);
    std::freopen("/dev/null", "w", stdout);
    ::execl(KILN_CLI_BIN, KILN_CLI_BIN, "bake", "material", "--model", "ggx", "--out", out.c_str(), "--server",
            k.address().c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Interrupt once the watch is under way.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!k.saw(v1::Request::kWatch) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << "kiln died of signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_TRUE(k.saw(v1::Request::kCancel));
  const std::string err = read(err_file);
  EXPECT_NE(err.find("kiln: job j1 cancelled (Ctrl-C); nothing was written to " + out.string()), std::string::npos)
      << err;
}

// `kiln bake lightmap`: the flags, a job file and an imported scene merge into one job (flags > job file > scene)
// that the daemon's translation accepts; a job file giving meshes is refused; server fields map back to their origin.
TEST(BakeLightmapFlags, FlagsJobFileAndSceneMerge) {
  const fs::path dir = fs::temp_directory_path() / ("kiln-lightmap-flags-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path job = dir / "job.textproto";
  std::ofstream(job) << "material_overrides { name: \"white\" bsdf { specular { ggx { alpha: 0.2 } } } }\n"
                        "lights { name: \"sun\" directional { direction { y: -1 } } }\n"
                        "resolution: 128\npadding: 2\n";
  LightmapBake bake = lightmap_bake_from_flags(std::vector<std::string>{"lightmap",
                                                                        "scene.gltf",
                                                                        "--job",
                                                                        job.string(),
                                                                        "--resolution",
                                                                        "32",
                                                                        "--env-constant",
                                                                        "0.5",
                                                                        "--env-intensity",
                                                                        "2",
                                                                        "--target-error",
                                                                        "0.05",
                                                                        "--max-samples",
                                                                        "512",
                                                                        "--time-limit",
                                                                        "20",
                                                                        "--ao",
                                                                        "--denoise",
                                                                        "--error-metric",
                                                                        "texel",
                                                                        "--no-preview",
                                                                        "--no-stitch-seams",
                                                                        "--generate-uvs",
                                                                        "always",
                                                                        "--force",
                                                                        "environment_sampling=on"});
  EXPECT_EQ(bake.scene_file, "scene.gltf");
  v1::LightmapJob imported;
  v1::Mesh* m = imported.add_meshes();
  m->set_name("floor");
  m->mutable_geometry()->set_sha256(std::string(64, 'a'));
  m->mutable_geometry()->set_size(100);
  imported.add_materials()->set_name("white");
  imported.add_lights()->mutable_point();
  merge_scene(bake, imported);
  const v1::LightmapJob& j = bake.spec.lightmap();
  EXPECT_EQ(j.meshes_size(), 1);
  EXPECT_EQ(j.lights_size(), 2);  // the scene's and the job file's
  EXPECT_EQ(j.material_overrides_size(), 1);
  EXPECT_EQ(j.resolution(), 32u);  // the flag over the job file
  EXPECT_EQ(j.padding(), 2u);      // the job file where no flag is given
  EXPECT_TRUE(j.ao());
  EXPECT_TRUE(j.denoise());
  EXPECT_EQ(j.error_metric(), v1::LIGHTMAP_ERROR_METRIC_TEXEL);
  EXPECT_FALSE(j.preview());
  EXPECT_FALSE(j.stitch_seams());
  EXPECT_EQ(j.generate_uvs(), v1::GENERATE_UVS_ALWAYS);
  EXPECT_EQ(j.environment().constant().g(), 0.5);
  EXPECT_EQ(j.environment().intensity(), 2);
  EXPECT_EQ(bake.spec.quality().samples(), 512u);
  EXPECT_EQ(bake.spec.quality().time_limit_seconds(), 20);
  EXPECT_TRUE(bake.spec.force_effects().at("environment_sampling"));
  const daemon::BakeRequest r = daemon::translate(bake.spec);
  EXPECT_EQ(r.lightmap().resolution, 32);
  EXPECT_TRUE(r.lightmap().denoise);
  EXPECT_FALSE(r.lightmap().stitch_seams);
  EXPECT_EQ(r.lightmap().generate_uvs, uvgen::GenerateUvs::always);
  EXPECT_EQ(r.lightmap().scene.materials[0].bsdf.specular.alpha_x, 0.2);
  EXPECT_EQ(r.lightmap().scene.lights[1].type, scene::LightShape::directional);

  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.resolution"), "--resolution");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.denoise"), "--denoise");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.error_metric"), "--error-metric");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.generate_uvs"), "--generate-uvs");
  EXPECT_EQ(lightmap_field_origin(bake, "job.quality.target_error"), "--target-error");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.environment.intensity"), "--env-intensity");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.meshes[0].geometry"), "scene.gltf");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.lights[0].color.r"), "scene.gltf");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.material_overrides[0].name"),
            job.string() + ":1:22");  // the column of `name` in the file

  std::ofstream(job) << "meshes { name: \"extra\" }\n";
  try {
    lightmap_bake_from_flags(std::vector<std::string>{"lightmap", "scene.gltf", "--job", job.string()});
    ADD_FAILURE() << "a job file with meshes was taken";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("meshes"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// Merges an imported scene of one mesh, "floor", into the bake (as the client does after the import).
void merge_floor_scene(LightmapBake& bake) {
  v1::LightmapJob imported;
  v1::Mesh* m = imported.add_meshes();
  m->set_name("floor");
  m->mutable_geometry()->set_sha256(std::string(64, 'a'));
  m->mutable_geometry()->set_size(100);
  merge_scene(bake, imported);
}

// The issue's example: --texel-density, --page-size and --max-pages set the job's atlas fields, the daemon's
// translation takes them, refusals map back to the flags, and the page flags alone are a usage error.
TEST(BakeLightmapFlags, AtlasFlagsMap) {
  LightmapBake bake = lightmap_bake_from_flags(std::vector<std::string>{
      "lightmap", "scene.gltf", "--texel-density", "20", "--page-size", "2048", "--max-pages", "2", "--out", "dir"});
  merge_floor_scene(bake);
  const v1::LightmapJob& j = bake.spec.lightmap();
  EXPECT_EQ(j.texel_density(), 20);
  EXPECT_EQ(j.page_size(), 2048u);
  EXPECT_EQ(j.max_pages(), 2u);
  const daemon::BakeRequest r = daemon::translate(bake.spec);
  EXPECT_EQ(r.lightmap().atlas.texel_density, 20);
  EXPECT_EQ(r.lightmap().atlas.page_size, 2048);
  EXPECT_EQ(r.lightmap().atlas.max_pages, 2);
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.texel_density"), "--texel-density");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.page_size"), "--page-size");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.max_pages"), "--max-pages");
  EXPECT_FALSE(j.has_uniform_pages());
  LightmapBake uniform = lightmap_bake_from_flags(std::vector<std::string>{
      "lightmap", "scene.gltf", "--texel-density", "20", "--uniform-pages", "--out", "dir"});
  merge_floor_scene(uniform);
  EXPECT_TRUE(uniform.spec.lightmap().uniform_pages());
  EXPECT_TRUE(daemon::translate(uniform.spec).lightmap().atlas.uniform_pages);
  EXPECT_EQ(lightmap_field_origin(uniform, "job.lightmap.uniform_pages"), "--uniform-pages");
  for (const auto& [args, flag] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--page-size", "512"}, "--page-size"},
           {{"--uniform-pages"}, "--uniform-pages"},
           {{"--texel-density", "20", "--max-pages", "0"}, "--max-pages"},
           {{"--texel-density", "0"}, "--texel-density"},
           {{"--texel-density", "20", "--page-size", "8"}, "--page-size"}}) {
    std::vector<std::string> all{"lightmap", "scene.gltf"};
    all.insert(all.end(), args.begin(), args.end());
    try {
      lightmap_bake_from_flags(all);
      ADD_FAILURE() << "took " << flag;
    } catch (const UsageError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(flag, 0), 0u) << e.what();
    }
  }
}

// --memory-limit sets the bake's memory budget (binary suffixes), the daemon takes it, and sizes outside
// [64 MiB, 1 PiB] or malformed are usage errors naming the flag.
TEST(BakeLightmapFlags, MemoryLimitFlagMaps) {
  LightmapBake bake = lightmap_bake_from_flags(
      std::vector<std::string>{"lightmap", "scene.gltf", "--memory-limit", "3G", "--out", "dir"});
  merge_floor_scene(bake);
  EXPECT_EQ(bake.spec.lightmap().memory_limit_bytes(), uint64_t{3} << 30);
  EXPECT_EQ(daemon::translate(bake.spec).lightmap().memory_limit_bytes, uint64_t{3} << 30);
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.memory_limit_bytes"), "--memory-limit");
  for (const char* bad : {"63M", "2P", "1.5G", "4GB", "-1", ""}) {
    try {
      lightmap_bake_from_flags(std::vector<std::string>{"lightmap", "scene.gltf", "--memory-limit", bad});
      ADD_FAILURE() << "took --memory-limit " << bad;
    } catch (const UsageError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--memory-limit", 0), 0u) << e.what();
    }
  }
}

// --fog adds a grey fog after the job file's media, the daemon's translation takes both, --vdb fills the job file's
// vdb medium that gives no file, refusals map back to the flag or the job file, and malformed values are usage
// errors naming --fog.
TEST(BakeLightmapFlags, MediaFromTheFogFlagAndTheJobFile) {
  const fs::path dir = fs::temp_directory_path() / ("kiln-media-flags-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path job = dir / "job.textproto";
  std::ofstream(job) << "media { name: \"smoke\" vdb { density_grid: \"density\" } sigma_s { r: 2 g: 2 b: 2 } }\n"
                        "media { name: \"mist\" box { lo { x: -1 } hi { x: 1 y: 1 z: 1 } } sigma_a { r: 0.5 } }\n";
  LightmapBake bake = lightmap_bake_from_flags(std::vector<std::string>{
      "lightmap", "scene.gltf", "--job", job.string(), "--fog", "0.01,0.05,0.3", "--vdb", "smoke.vdb"});
  EXPECT_EQ(bake.vdb_file, "smoke.vdb");
  merge_floor_scene(bake);
  v1::Digest d;
  d.set_sha256(std::string(64, 'c'));
  d.set_size(4000);
  set_vdb_digest(bake, d);
  const v1::LightmapJob& j = bake.spec.lightmap();
  ASSERT_EQ(j.media_size(), 3);
  EXPECT_EQ(j.media(0).vdb().file().sha256(), d.sha256());
  EXPECT_TRUE(j.media(2).fog());  // the flag's, last
  EXPECT_EQ(j.media(2).sigma_a().g(), 0.01);
  EXPECT_EQ(j.media(2).sigma_s().b(), 0.05);
  EXPECT_EQ(j.media(2).g(), 0.3);
  const daemon::BakeRequest r = daemon::translate(bake.spec);
  ASSERT_EQ(r.lightmap().media.size(), 3u);
  EXPECT_EQ(std::get<volume::HomogeneousMediumSpec>(r.lightmap().media[1].spec).sigma_a.r, 0.5);
  EXPECT_EQ(std::get<volume::HomogeneousMediumSpec>(r.lightmap().media[2].spec).sigma_s.g, 0.05);
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.media[2].g"), "--fog");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.media[0].vdb.file"), "smoke.vdb");
  EXPECT_EQ(lightmap_field_origin(bake, "job.lightmap.media[1].sigma_a.r"), job.string() + ":2:75");
  for (const std::string bad : {"1", "1,2,3,4", "-1,0", "0,0,2", "a,b"}) {
    try {
      lightmap_bake_from_flags(std::vector<std::string>{"lightmap", "scene.gltf", "--fog", bad});
      ADD_FAILURE() << "took --fog " << bad;
    } catch (const UsageError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--fog", 0), 0u) << e.what();
    }
  }
  try {  // no medium waits for the file
    lightmap_bake_from_flags(std::vector<std::string>{"lightmap", "scene.gltf", "--vdb", "smoke.vdb"});
    ADD_FAILURE() << "took --vdb without a vdb medium";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--vdb", 0), 0u) << e.what();
  }
  fs::remove_all(dir);
}


// `kiln bake probes`: the probe flags over a job file's probes block become a probes job whose scene is the lightmap
// bake's, the daemon's translation takes it, refusals map back to the flag or the file, and lightmap-only flags and a
// missing spacing are usage errors. `--probes` on a lightmap bake sets the lightmap job's probes.
TEST(BakeProbesFlags, FlagsAndJobFileBecomeAProbesJob) {
  const fs::path dir = fs::temp_directory_path() / ("kiln-probes-flags-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path job = dir / "job.textproto";
  std::ofstream(job) << "probes { max_distance: 3 max_probes: 5000 }\n";
  auto bake_of = [](const std::vector<std::string>& args) {
    return lightmap_bake_from_flags(parse_flags(args, bake_probes_flag_specs(), "kiln bake probes"));
  };
  LightmapBake bake = bake_of({"probes", "scene.gltf", "--job", job.string(), "--spacing", "0.5", "--max-distance",
                               "1.5", "--region", "-1,0,-1,1,2,1", "--target-error", "0.05"});
  merge_floor_scene(bake);
  make_probes_job(bake.spec);
  ASSERT_TRUE(bake.spec.has_probes());
  const v1::ProbeVolume& v = bake.spec.probes().volume();
  EXPECT_EQ(v.spacing(), 0.5);
  EXPECT_EQ(v.max_distance(), 1.5);  // the flag over the file
  EXPECT_EQ(v.max_probes(), 5000u);  // the file's
  ASSERT_EQ(v.regions_size(), 1);
  EXPECT_EQ(v.regions(0).hi().y(), 2);
  EXPECT_FALSE(bake.spec.probes().scene().has_probes());
  EXPECT_EQ(bake.spec.probes().scene().meshes(0).name(), "floor");
  const daemon::BakeRequest r = daemon::translate(bake.spec);
  EXPECT_STREQ(daemon::job_type(r), "probes");
  EXPECT_EQ(r.lightmap().probes.spacing, 0.5);
  EXPECT_EQ(probes_field_origin(bake, "job.probes.volume.spacing"), "--spacing");
  EXPECT_EQ(probes_field_origin(bake, "job.probes.volume.regions[0].hi"), "--region");
  EXPECT_EQ(probes_field_origin(bake, "job.probes.volume.max_probes"), job.string() + ":1:26");
  EXPECT_EQ(probes_field_origin(bake, "job.quality.target_error"), "--target-error");
  EXPECT_EQ(probes_field_origin(bake, "job.probes.scene.meshes[0].geometry"), "scene.gltf");
  auto usage = [&](const std::vector<std::string>& args) -> std::string {
    try {
      LightmapBake b = bake_of(args);
      merge_floor_scene(b);
      make_probes_job(b.spec);
    } catch (const UsageError& e) {
      return e.what();
    }
    return "(accepted)";
  };
  EXPECT_EQ(usage({"probes", "scene.gltf"}).rfind("--spacing: missing", 0), 0u);
  EXPECT_EQ(usage({"probes", "scene.gltf", "--spacing", "0"}).rfind("--spacing", 0), 0u);
  EXPECT_EQ(usage({"probes", "scene.gltf", "--spacing", "1", "--region", "0,0,0,1,1"}).rfind("--region", 0), 0u);
  // A lightmap-only flag is not one of `kiln bake probes`'s.
  EXPECT_NE(usage({"probes", "scene.gltf", "--spacing", "1", "--resolution", "8"}).find("--resolution"),
            std::string::npos);

  LightmapBake both = lightmap_bake_from_flags(
      std::vector<std::string>{"lightmap", "scene.gltf", "--probes", "0.25", "--max-probes", "100"});
  merge_floor_scene(both);
  EXPECT_EQ(both.spec.lightmap().probes().spacing(), 0.25);
  EXPECT_EQ(both.spec.lightmap().probes().max_probes(), 100u);
  EXPECT_EQ(lightmap_field_origin(both, "job.lightmap.probes.spacing"), "--probes");
  try {
    lightmap_bake_from_flags(std::vector<std::string>{"lightmap", "scene.gltf", "--max-distance", "1"});
    ADD_FAILURE() << "took --max-distance without --probes";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--max-distance", 0), 0u) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kiln::cli
