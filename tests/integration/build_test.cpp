// `kiln build` against the real kilnd (issue 24): a manifest of 20 tiny bakes (12 materials from commands, 6
// environments from a glob over generated skies, 2 lightmaps of the generated Cornell box) built four times: first
// everything bakes; then everything is a cache hit and no output file is touched (same inode, same modification
// time); then one changed input bakes again, alone; then a bake that misses its check fails the build, the JUnit
// report says which and why, and the other outputs are written. Every JUnit report is validated against the Jenkins
// JUnit schema (tests/integration/junit.xsd) with xmllint.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <nlohmann/json.hpp>

#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "tests/integration/daemon_fixture.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"

namespace kiln {
namespace {

#ifdef KILN_BIN
namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr int kMaterials = 12;
const char* const kSkies[] = {"sky_a", "sky_b", "sky_c", "sky_d", "sky_e", "sky_f"};

const std::string kSchema = std::string(KILN_SOURCE_DIR) + "/tests/integration/junit.xsd";

// What says whether a file was rewritten: its inode (a rename puts a new one in place) and modification time.
struct Stamp {
  ino_t inode = 0;
  long long mtime_ns = 0;
  bool operator==(const Stamp&) const = default;
};

std::map<std::string, Stamp> stamps_under(const fs::path& dir) {
  std::map<std::string, Stamp> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    struct stat st {};
    if (stat(e.path().c_str(), &st) != 0) continue;
    out[fs::relative(e.path(), dir).string()] = {st.st_ino, st.st_mtim.tv_sec * 1'000'000'000LL + st.st_mtim.tv_nsec};
  }
  return out;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Material i's alpha: distinct, so that every material is its own job.
std::string alpha_of(int i) { return std::to_string(0.05 * (i + 2)).substr(0, 4); }

class BuildTest : public ::testing::Test {
 protected:
  void SetUp() override {
    token_ = (tmp_.path() / "token").string();
    std::ofstream(token_) << daemon_.token() << "\n";
    fs::create_directories(tmp_.path() / "skies");
    for (int i = 0; i < 6; ++i) make_sky(kSkies[i], 10 + 10 * i);
    const std::string box = (tmp_.path() / "box.gltf").string();
    ASSERT_EQ(test::run_command("/usr/bin/python3 " + std::string(KILN_SOURCE_DIR) +
                                "/client/examples/scenes/cornell_box.py " + box + " 2>&1")
                  .status,
              0);
  }

  void make_sky(const std::string& name, int sun_elevation) {
    const std::string sky = (fs::path(KILN_BIN).parent_path() / "kiln-sky").string();
    const auto r = test::run_command(sky + " --width 16 --sun-elevation " + std::to_string(sun_elevation) + " --out " +
                                     (tmp_.path() / "skies" / (name + ".exr")).string() + " 2>&1");
    ASSERT_EQ(r.status, 0) << r.output;
  }

  // The manifest: 12 materials, a glob of 6 skies, 2 lightmaps. `material_4_alpha` changes material 4's job;
  // `strict_bake` gets a check no bake can meet.
  void write_manifest(const std::string& material_4_alpha = alpha_of(4), const std::string& strict_bake = "") {
    std::ofstream m(tmp_.path() / "kiln.build.textproto");
    for (int i = 0; i < kMaterials; ++i) {
      const std::string name = "mat_" + std::to_string(i);
      m << "bake {\n  name: \"" << name << "\"\n  command: \"material --model ggx --alpha "
        << (i == 4 ? material_4_alpha : alpha_of(i))
        << " --fresnel schlick --f0 0.04 --table-mu 8 --table-roughness 4 --samples 64 --no-preview\"\n"
        << "  output: \"out/" << name << "\"\n";
      if (name == strict_bake) m << "  checks { max_error: 1e-12 }\n";
      m << "}\n";
    }
    m << "bake {\n  name: \"skies\"\n  command: \"env --size 4 --samples 4 --irradiance-size 4 --dfg-size 8 "
         "--dfg-samples 16 --no-preview\"\n  inputs: \"skies/*.exr\"\n  output: \"out/skies\"\n}\n";
    for (int res : {8, 16}) {
      m << "bake {\n  name: \"box_" << res << "\"\n  command: \"lightmap box.gltf --resolution " << res
        << " --max-samples 16 --target-error 0.5 --no-preview\"\n  output: \"out/box_" << res
        << "\"\n  checks { max_invalid_texels: 1 }\n}\n";
    }
  }

  // `kiln build` in the manifest's folder, with both reports; returns the exit status, fills output and summary.
  int build() {
    const fs::path junit = tmp_.path() / "junit.xml", json = tmp_.path() / "build.json";
    const auto r = test::run_command("cd " + tmp_.path().string() + " && " + KILN_BIN + " --server " + daemon_.tcp() +
                                     " --token-file " + token_ + " build --report-junit " + junit.string() +
                                     " --report-json " + json.string() + " 2>&1");
    output_ = r.output;
    summary_ = Json::parse(read_file(json));
    junit_ = read_file(junit);
    const auto valid = test::run_command("xmllint --noout --schema " + kSchema + " " + junit.string() + " 2>&1");
    EXPECT_EQ(valid.status, 0) << "the JUnit report does not follow the schema:\n" << valid.output << "\n" << junit_;
    return r.status;
  }

  const Json& result_of(const std::string& name) const {
    for (const Json& b : summary_["results"]) {
      if (b["name"] == name) return b;
    }
    throw std::runtime_error("no bake " + name + " in the summary");
  }

  test::TempDir tmp_{"kiln-build"};
  test::Daemon daemon_;
  std::string token_, output_, junit_;
  Json summary_;
};

TEST_F(BuildTest, BakesOnceThenHitsTheCacheRebakesWhatChangedAndFailsOnAMissedCheck) {
  write_manifest();
  const fs::path out = tmp_.path() / "out";

  // First build: all 20 bake.
  ASSERT_EQ(build(), 0) << output_;
  EXPECT_EQ(summary_["bakes"], 20) << output_;
  EXPECT_EQ(summary_["baked"], 20) << output_;
  EXPECT_EQ(summary_["cached"], 0);
  for (const char* sky : kSkies) EXPECT_TRUE(fs::exists(out / "skies" / sky / "report.json")) << sky;
  EXPECT_TRUE(fs::exists(out / "mat_0" / "albedo.exr"));
  EXPECT_TRUE(fs::exists(out / "box_16" / "report.json"));
  EXPECT_NE(output_.find("20 baked, 0 cached, 0 failed"), std::string::npos) << output_;
  const auto first = stamps_under(out);

  // Second build: all cache hits, no file rewritten (nor any added or removed).
  ASSERT_EQ(build(), 0) << output_;
  EXPECT_EQ(summary_["cached"], 20) << output_;
  EXPECT_EQ(summary_["baked"], 0);
  EXPECT_EQ(summary_["files_written"], 0);
  EXPECT_GT(summary_["saved_seconds"].get<double>(), 0.0);
  EXPECT_TRUE(stamps_under(out) == first) << "the all-cached build touched a file";
  EXPECT_NE(output_.find("0 baked, 20 cached, 0 failed"), std::string::npos) << output_;

  // A changed input: one sky bakes again; only its folder changes.
  make_sky("sky_c", 75);
  ASSERT_EQ(build(), 0) << output_;
  EXPECT_EQ(summary_["baked"], 1) << output_;
  EXPECT_EQ(summary_["cached"], 19);
  EXPECT_EQ(result_of("skies/sky_c")["status"], "baked");
  const auto third = stamps_under(out);
  for (const auto& [file, stamp] : first) {
    if (file.rfind("skies/sky_c/", 0) == 0) continue;
    EXPECT_TRUE(third.at(file) == stamp) << file << " was rewritten";
  }
  EXPECT_FALSE(third.at("skies/sky_c/report.json") == first.at("skies/sky_c/report.json"));

  // A bake that misses its check: the build fails, JUnit says which and why, its folder stays as it was, and the
  // other changed bake's outputs are written.
  write_manifest("0.77", "mat_3");
  EXPECT_EQ(build(), 1) << output_;
  EXPECT_EQ(summary_["failed"], 1) << output_;
  EXPECT_EQ(result_of("mat_3")["status"], "failed");
  EXPECT_EQ(result_of("mat_3")["failure"]["type"], "checks.max_error");
  EXPECT_EQ(result_of("mat_4")["status"], "baked");
  const std::string failed_case = junit_.substr(junit_.find("<testcase name=\"mat_3\""));
  const std::string failure = failed_case.substr(0, failed_case.find("</testcase>"));
  EXPECT_NE(failure.find("<failure message=\"checks.max_error: error estimate"), std::string::npos) << failure;
  EXPECT_NE(failure.find("is above the limit 1e-12"), std::string::npos) << failure;
  EXPECT_NE(output_.find("FAILED mat_3: checks.max_error"), std::string::npos) << output_;
  const auto fourth = stamps_under(out);
  for (const auto& [file, stamp] : third) {
    if (file.rfind("mat_4/", 0) == 0) continue;
    EXPECT_TRUE(fourth.at(file) == stamp) << file << " was rewritten";
  }
  EXPECT_FALSE(fourth.at("mat_4/albedo.exr") == third.at("mat_4/albedo.exr")) << "mat_4's new outputs were not written";
}

// The schema is not vacuous: it refuses a test case without a name and a suite without its count of tests.
TEST(JunitSchema, RefusesMalformedReports) {
  test::TempDir tmp("kiln-junit");
  const fs::path bad = tmp.path() / "bad.xml";
  std::ofstream(bad) << "<testsuites><testsuite name=\"x\"><testcase time=\"1.0\"/></testsuite></testsuites>\n";
  const auto r = test::run_command("xmllint --noout --schema " + kSchema + " " + bad.string() + " 2>&1");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("tests"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("name"), std::string::npos) << r.output;
}
#endif

}  // namespace
}  // namespace kiln
