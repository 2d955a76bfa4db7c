// kiln build without a daemon: the manifest's errors name their file, line and column; commands split and parse as
// `kiln bake` would, with the flags a build gives itself refused; globs, --only and checks that do not apply are
// refused before anything is sent; checks measure what they say; JUnit text is escaped.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "client/cli/args.h"
#include "client/cli/build_checks.h"
#include "client/cli/build_junit.h"
#include "client/cli/build_manifest.h"
#include "client/cli/build_plan.h"
#include "proto/kiln.pb.h"
#include "tests/support/temp_dir.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;

class Manifests : public ::testing::Test {
 protected:
  fs::path write(const std::string& text) {
    const fs::path p = tmp_.path() / kManifestName;
    std::ofstream(p) << text;
    return p;
  }
  // The UsageError read_manifest (and, with `plan`, plan_build) throws for `text`.
  std::string error_of(const std::string& text, bool plan = false, const std::vector<std::string>& only = {}) {
    const fs::path p = write(text);
    try {
      const Manifest m = read_manifest(p.string());
      if (plan) {
        std::ostringstream err;
        plan_build(m, only, err);
      }
    } catch (const UsageError& e) {
      return e.what();
    }
    return "(no error)";
  }
  test::TempDir tmp_{"kiln-manifest"};
};

const std::string kMaterial = "command: \"material --model ggx --alpha 0.3 --samples 64\"";

TEST_F(Manifests, ReadsBakesWithPathsRelativeToTheManifest) {
  const fs::path p = write("bake { name: \"a\" " + kMaterial +
                           " output: \"out/a\" priority: 5 checks { max_error: 0.01 } }\n"
                           "bake { name: \"b\" job_file: \"jobs/b.textproto\" output: \"/abs/b\" }\n");
  const Manifest m = read_manifest(tmp_.path().string());  // a folder means its kiln.build.textproto
  ASSERT_EQ(m.bakes.size(), 2u);
  EXPECT_EQ(m.bakes[0].output, tmp_.path() / "out/a");
  EXPECT_EQ(m.bakes[0].priority, 5);
  EXPECT_EQ(m.bakes[0].checks.max_error, 0.01);
  EXPECT_EQ(m.bakes[0].command.size(), 7u);
  EXPECT_EQ(m.bakes[1].job_file, tmp_.path() / "jobs/b.textproto");
  EXPECT_EQ(m.bakes[1].output, fs::path("/abs/b"));
  EXPECT_EQ(m.bakes[1].origin, p.string() + ":2:1");
}

TEST_F(Manifests, ErrorsNameTheLineAndSayWhatToDo) {
  const std::string f = (tmp_.path() / kManifestName).string();
  EXPECT_EQ(error_of("bake { name: \"a\" colour: 1 }"),
            f + ":1:18: Message type \"kiln.build.v1.Bake\" has no field named \"colour\".");
  EXPECT_EQ(error_of("bake { name: \"a\" " + kMaterial + " output: \"o\" }\nbake { name: \"a\" " + kMaterial +
                     " output: \"p\" }"),
            f + ":2:8: a second bake named \"a\" (the first is at " + f + ":1:1); names must be unique");
  EXPECT_EQ(error_of("bake { name: \"a\" " + kMaterial + " }"),
            f + ":1:1: bake \"a\" needs an output folder: add `output: \"DIR\"`");
  EXPECT_EQ(error_of("bake { name: \"a b\" " + kMaterial + " output: \"o\" }"),
            f + ":1:1: name \"a b\": use letters, digits, '_', '-' and '.' only");
  EXPECT_EQ(
      error_of("bake { name: \"a\" output: \"o\" }"),
      f + ":1:1: bake \"a\" says nothing to bake: give `job_file: \"FILE.textproto\"` or `command: \"material ...\"`");
  EXPECT_EQ(error_of("bake { name: \"a\" job_file: \"j\" inputs: \"*.exr\" output: \"o\" }"),
            f + ":1:32: bake \"a\": inputs (a glob) go with a command (`command: \"env --size 128\"`), not a job file");
  EXPECT_EQ(error_of("bake { name: \"a\" " + kMaterial + " output: \"o\" }\nbake { name: \"b\" " + kMaterial +
                     " output: \"o\" }"),
            f + ":2:" + std::to_string(18 + kMaterial.size() + 1) + ": bake \"b\" writes into " +
                (tmp_.path() / "o").string() + " like the bake at " + f + ":1:1; give each its own folder");
  EXPECT_EQ(
      error_of("bake { name: \"a\" " + kMaterial + " output: \"o\" checks { max_invalid_texels: 2 } }"),
      f + ":1:" + std::to_string(18 + kMaterial.size() + 13) + ": checks.max_invalid_texels: must be in [0, 1], got 2");
  EXPECT_EQ(error_of(""), f + ": no bakes; add `bake { name: ... output: ... }` entries");
  EXPECT_NE(error_of("bake {").find(f + ":1:7: "), std::string::npos);
}

TEST_F(Manifests, CommandsAreKilnBakeLinesWithoutTheFlagsABuildGives) {
  EXPECT_EQ(split_command("env 'my sky.exr' --size \"128\"  x", "M"),
            (std::vector<std::string>{"env", "my sky.exr", "--size", "128", "x"}));
  EXPECT_THROW(split_command("env 'sky.exr", "M"), UsageError);
  const std::string f = (tmp_.path() / kManifestName).string();
  EXPECT_EQ(error_of("bake { name: \"a\" command: \"material --model ggx --alpha 0.3 --out x\" output: \"o\" }", true),
            f + ":1:1: bake \"a\": command: --out has no place in a manifest; use the bake's `output` folder");
  EXPECT_EQ(error_of("bake { name: \"a\" command: \"material --model ggx --alpha 2\" output: \"o\" }", true),
            f + ":1:1: bake \"a\": --alpha: must be in (0, 1], got 2");
  EXPECT_EQ(error_of("bake { name: \"a\" command: \"probe x\" output: \"o\" }", true),
            f + ":1:1: bake \"a\": command: unknown bake type 'probe': expected material, env, lightmap or probes");
  EXPECT_EQ(error_of("bake { name: \"a\" command: \"env sky.exr\" output: \"o\" }", true),
            f + ":1:1: bake \"a\": " + (tmp_.path() / "sky.exr").string() +
                ": no such file (the environment to bake: an equirectangular EXR, HDR, PNG or JPEG)");
  fs::create_directories(tmp_.path() / "skies");
  EXPECT_EQ(error_of("bake { name: \"s\" command: \"env --size 4\" inputs: \"skies/*.exr\" output: \"o\" }", true),
            f + ":1:1: bake \"s\": inputs " + (tmp_.path() / "skies/*.exr").string() + " matches no file");
  EXPECT_EQ(error_of("bake { name: \"a\" " + kMaterial + " output: \"o\" checks { max_invalid_texels: 0.5 } }", true),
            f + ":1:1: bake \"a\": checks.max_invalid_texels applies to lightmap bakes; this one is a material bake");
  EXPECT_EQ(error_of("bake { name: \"a\" " + kMaterial + " output: \"o\" }", true, {"b"}),
            "--only b: no bake of that name in " + f + " (a glob's bakes are NAME or NAME/STEM)");
}

TEST_F(Manifests, AGlobPlansOneBakePerFileAndOnlyPicksByName) {
  fs::create_directories(tmp_.path() / "skies");
  for (const char* s : {"noon.exr", "dusk.exr", "notes.txt"}) std::ofstream(tmp_.path() / "skies" / s) << s;
  const fs::path p = write(
      "bake { name: \"skies\" command: \"env --size 4\" inputs: \"skies/*.exr\" output: \"out\" }\n"
      "bake { name: \"m\" " +
      kMaterial + " output: \"m\" }\n");
  std::ostringstream err;
  const BuildPlan all = plan_build(read_manifest(p.string()), {}, err);
  ASSERT_EQ(all.bakes.size(), 3u);
  EXPECT_EQ(all.bakes[0].name, "skies/dusk");
  EXPECT_EQ(all.bakes[0].output, tmp_.path() / "out" / "dusk");
  EXPECT_EQ(all.bakes[0].type, "environment");
  EXPECT_EQ(all.bakes[1].name, "skies/noon");
  EXPECT_EQ(all.blobs.size(), 2u);  // the two images, by digest
  EXPECT_EQ(all.bakes[0].where("job.environment.image"), (tmp_.path() / "skies" / "dusk.exr").string());
  EXPECT_EQ(plan_build(read_manifest(p.string()), {"skies/noon"}, err).bakes.size(), 1u);
  EXPECT_EQ(plan_build(read_manifest(p.string()), {"skies", "m"}, err).bakes.size(), 3u);
}

v1::JobResult result_with(double error, double seconds, const std::string& report_json) {
  v1::JobResult r;
  r.set_state(v1::JOB_STATE_SUCCEEDED);
  r.mutable_report()->set_error_estimate(error);
  r.mutable_report()->set_seconds(seconds);
  r.mutable_report()->set_json(report_json);
  return r;
}

TEST(BuildChecks, MeasureWhatTheySayAndNameTheLimit) {
  BakeChecks c;
  c.max_error = 1e-3;
  c.max_seconds = 10;
  EXPECT_TRUE(run_checks(c, result_with(1e-3, 10, "")).empty());  // the limits themselves pass
  auto f = run_checks(c, result_with(2e-3, 11, ""));
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f[0].check, "checks.max_error");
  EXPECT_NE(f[0].message.find("error estimate 0.002 is above the limit 0.001"), std::string::npos) << f[0].message;
  EXPECT_EQ(f[1].check, "checks.max_seconds");
  EXPECT_EQ(run_checks(c, result_with(-1, 1, ""))[0].message.substr(0, 53),
            "checks.max_error: the bake reported no error estimate");

  BakeChecks m;
  m.energy_conserving = true;
  m.max_reciprocity_error = 1e-6;
  const std::string ok =
      R"({"validation":{"energy":{"conserves_energy":true},"reciprocity":{"max_relative_difference":1e-7}}})";
  EXPECT_TRUE(run_checks(m, result_with(0, 0, ok)).empty());
  const std::string bad = R"({"validation":{"energy":{"conserves_energy":false,"white_furnace_max_albedo":1.02},)"
                          R"("reciprocity":{"max_relative_difference":0.3}}})";
  f = run_checks(m, result_with(0, 0, bad));
  ASSERT_EQ(f.size(), 2u);
  EXPECT_NE(f[0].message.find("white furnace up to 1.02"), std::string::npos) << f[0].message;
  EXPECT_NE(f[1].message.find("differ by up to 0.3 (relative), above the limit 1e-06"), std::string::npos);
  EXPECT_EQ(run_checks(m, result_with(0, 0, "{}")).size(), 2u);  // no figures: the checks cannot pass

  BakeChecks l;
  l.max_invalid_texels = 0.25;
  // Two 4x4 lightmaps, 13 and 11 of 16 texels valid: 8 of 32 invalid, exactly the limit.
  const std::string maps = R"({"lightmaps":[{"resolution":4,"valid_texels":13},{"resolution":4,"valid_texels":11}]})";
  EXPECT_TRUE(run_checks(l, result_with(0, 0, maps)).empty());
  l.max_invalid_texels = 0.2;
  f = run_checks(l, result_with(0, 0, maps));
  ASSERT_EQ(f.size(), 1u);
  EXPECT_NE(f[0].message.find("25% of the lightmaps' texels are invalid (8 of 32"), std::string::npos) << f[0].message;
}

TEST(BuildJunit, EscapesMarkupAndControlCharacters) {
  EXPECT_EQ(xml_escape("a<b>&\"c'\n\x01\x1b"), "a&lt;b&gt;&amp;&quot;c&apos;\n\xEF\xBF\xBD\xEF\xBF\xBD");
}

}  // namespace
}  // namespace kiln::cli
