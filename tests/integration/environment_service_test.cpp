// The environment job end to end: an image generated here is uploaded to the real kilnd, baked, and its outputs
// fetched and checked; images the decoder refuses fail the job with the decoder's message, and the daemon goes on.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "bakers/envmap/environment_bake.h"
#include "bakers/image/exr.h"
#include "client/lib/client.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/service_client.h"
#include "tests/support/run_command.h"

namespace kiln {
namespace {

using client::Client;
using test::connect;
using test::Daemon;

// A W x H equirectangular RGB image: a smooth sky over a darker ground, with a bright patch (a small sun).
image::FloatImage sky_image(int width = 64, int height = 32) {
  image::FloatImage img;
  img.width = width;
  img.height = height;
  img.channels = 3;
  img.channel_names = {"R", "G", "B"};
  img.pixels.resize(static_cast<size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool sky = y < height / 2;
      const float t = float(y) / height;
      img.at(x, y, 0) = sky ? 0.3f + t : 0.1f;
      img.at(x, y, 1) = sky ? 0.5f + t : 0.08f;
      img.at(x, y, 2) = sky ? 1.0f : 0.06f;
    }
  }
  for (int c = 0; c < 3; ++c) img.at(width / 4, height / 4, c) = 500.0f;
  return img;
}

// The small, fast settings every job here uses: a 16^2 cube (levels 16, 8, 4), fixed samples, a small DFG table.
v1::JobSpec environment_job(const v1::Digest& image) {
  v1::JobSpec spec;
  spec.set_name("environment test");
  v1::EnvironmentJob* e = spec.mutable_environment();
  *e->mutable_image() = image;
  e->set_size(16);
  e->set_irradiance_size(8);
  e->set_dfg_size(8);
  e->set_dfg_samples(64);
  spec.mutable_quality()->set_samples(32);
  spec.mutable_quality()->set_seed(1);
  return spec;
}

std::set<std::string> expected_names(int levels) {
  std::set<std::string> names{"specular.ktx2", "sh.txt", "dfg.exr", "report.json"};
  for (const char* f : {"px", "nx", "py", "ny", "pz", "nz"}) {
    names.insert(std::string("irradiance_") + f + ".exr");
    for (int k = 0; k < levels; ++k) names.insert("specular_L" + std::to_string(k) + "_" + f + ".exr");
  }
  return names;
}

// Every output fetched (the library verifies each digest; checked again here) and every EXR decoded; returns the
// outputs by name. Fails the test on a non-finite or negative value in any radiance EXR.
std::map<std::string, std::string> fetch_and_check(Client& c, const v1::JobResult& r) {
  std::map<std::string, std::string> out;
  for (const v1::Output& o : r.outputs()) {
    const std::string bytes = c.fetch(o.digest());
    EXPECT_EQ(bytes.size(), o.digest().size()) << o.name();
    EXPECT_EQ(proto::sha256_hex(bytes), o.digest().sha256()) << o.name();
    if (o.name().size() > 4 && o.name().substr(o.name().size() - 4) == ".exr") {
      EXPECT_EQ(o.media_type(), "image/x-exr") << o.name();
      const image::FloatImage img = image::decode_exr(bytes);  // throws if it is not a readable EXR
      EXPECT_GT(img.width, 0) << o.name();
      size_t bad = 0;
      for (float v : img.pixels) bad += !std::isfinite(v) || v < 0;
      EXPECT_EQ(bad, 0u) << o.name() << " holds non-finite or negative values";
      EXPECT_EQ(o.color_space(), o.name() == "dfg.exr" ? "data" : "lin_rec709") << o.name();
    }
    out[o.name()] = bytes;
  }
  return out;
}

// A job that is expected to fail: its result's error.
v1::Error failure_of(Client& c, const v1::JobSpec& spec) {
  const v1::SubmitReply sub = c.submit(spec);
  const v1::JobEvent last = c.watch(sub.job_id());
  EXPECT_EQ(last.state(), v1::JOB_STATE_FAILED) << last.message();
  EXPECT_FALSE(last.message().empty());
  const v1::JobResult r = c.result(sub.job_id());
  EXPECT_EQ(r.state(), v1::JOB_STATE_FAILED);
  EXPECT_EQ(r.outputs_size(), 0);
  return r.error();
}

TEST(EnvironmentService, UploadedExrBakesOutputsVerifyAndTheSecondSubmitIsACacheHit) {
  Daemon d;
  Client c = connect(d);
  const v1::Digest image = c.upload_blob(image::encode_exr(sky_image()));
  const v1::SubmitReply sub = c.submit(environment_job(image));
  EXPECT_FALSE(sub.cache_hit());
  const v1::JobEvent last = c.watch(sub.job_id());
  ASSERT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED) << last.message() << d.log();
  const v1::JobResult r = c.result(sub.job_id());
  const auto outputs = fetch_and_check(c, r);
  std::set<std::string> names;
  for (const auto& [name, bytes] : outputs) names.insert(name);
  // preview.png is the baker's to write (asked for by default); the rest is fixed by the 16^2 cube's 3 levels.
  std::set<std::string> expected = expected_names(3);
  if (names.count("preview.png")) expected.insert("preview.png");
  EXPECT_EQ(names, expected);
  for (const v1::Output& o : r.outputs()) {
    if (o.name() == "specular.ktx2") {
      EXPECT_EQ(o.media_type(), "image/ktx2");
    }
    if (o.name() == "report.json") {
      EXPECT_EQ(o.media_type(), "application/json");
    }
    EXPECT_FALSE(o.description().empty()) << o.name();
  }
  EXPECT_EQ(r.report().baker_version(), envmap::kEnvironmentBakerVersion);
  EXPECT_GT(r.report().samples(), 0u);
  EXPECT_GT(r.report().seconds(), 0.0);
  EXPECT_GT(r.report().error_estimate(), 0.0);  // the largest level's error: a non-constant sky has one
  EXPECT_EQ(r.report().json(), outputs.at("report.json"));
  bool source = false;
  for (const v1::PlanDecision& p : r.report().plan()) source |= p.effect() == "source" && p.enabled();
  EXPECT_TRUE(source);

  // The same bake under another name: answered from the cache with the same bytes.
  v1::JobSpec again = environment_job(image);
  again.set_name("another name, same bake");
  const v1::SubmitReply second = c.submit(again);
  EXPECT_TRUE(second.cache_hit());
  const v1::JobResult r2 = c.result(second.job_id());
  ASSERT_EQ(r2.outputs_size(), r.outputs_size());
  for (int i = 0; i < r.outputs_size(); ++i) EXPECT_EQ(r2.outputs(i).digest().sha256(), r.outputs(i).digest().sha256());
  // Another setting is another bake.
  v1::JobSpec other = environment_job(image);
  other.mutable_environment()->set_rotation_degrees(90);
  EXPECT_FALSE(c.submit(other).cache_hit());
}

// The DFG table does not depend on the environment: kilnd keeps it in its store's tables/, so a restarted kilnd's
// next job of the same lobe takes it (report.json's dfg_table says from where) and writes the same dfg.exr.
TEST(EnvironmentService, ARestartedDaemonTakesTheDfgTableFromItsStore) {
  std::filesystem::path dir;
  std::string first_dfg;
  {
    Daemon d;
    d.keep();
    dir = d.dir();
    Client c = connect(d);
    const v1::SubmitReply sub = c.submit(environment_job(c.upload_blob(image::encode_exr(sky_image()))));
    ASSERT_EQ(c.watch(sub.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << d.log();
    const auto outputs = fetch_and_check(c, c.result(sub.job_id()));
    EXPECT_EQ(nlohmann::json::parse(outputs.at("report.json"))["dfg_table"], "computed");
    first_dfg = outputs.at("dfg.exr");
    int tables = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir / "store" / "tables"))
      tables += e.path().extension() == ".bin";
    EXPECT_EQ(tables, 1);
  }
  Daemon again({}, dir);
  Client c = connect(again);
  v1::JobSpec other = environment_job(c.upload_blob(image::encode_exr(sky_image())));
  other.mutable_environment()->set_rotation_degrees(45);  // another bake, not a cache hit
  const v1::SubmitReply sub = c.submit(other);
  ASSERT_FALSE(sub.cache_hit());
  ASSERT_EQ(c.watch(sub.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << again.log();
  const auto outputs = fetch_and_check(c, c.result(sub.job_id()));
  EXPECT_EQ(nlohmann::json::parse(outputs.at("report.json"))["dfg_table"], "kept in the store");
  EXPECT_EQ(outputs.at("dfg.exr"), first_dfg);
}

TEST(EnvironmentService, AConstantEnvironmentGivesItsAnalyticOutputs) {
  // A constant radiance L: every prefiltered texel is L (a normalised filter of a constant), and the irradiance is
  // E = integral of L cos over the hemisphere = pi L.
  Daemon d;
  Client c = connect(d);
  v1::JobSpec spec;
  v1::EnvironmentJob* e = spec.mutable_environment();
  e->mutable_constant()->set_r(0.5);
  e->mutable_constant()->set_g(1.0);
  e->mutable_constant()->set_b(2.0);
  e->set_size(16);
  e->set_irradiance_size(8);
  e->set_dfg_size(8);
  e->set_dfg_samples(64);
  e->set_preview(false);
  spec.mutable_quality()->set_samples(16);
  const v1::SubmitReply sub = c.submit(spec);
  ASSERT_EQ(c.watch(sub.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << d.log();
  const auto outputs = fetch_and_check(c, c.result(sub.job_id()));
  EXPECT_EQ(outputs.count("preview.png"), 0u);  // preview: false
  const double L[3] = {0.5, 1.0, 2.0};
  constexpr double kPi = 3.14159265358979323846;
  for (const auto& [name, bytes] : outputs) {
    const bool specular = name.rfind("specular_L", 0) == 0, irradiance = name.rfind("irradiance_", 0) == 0;
    if (!specular && !irradiance) continue;
    const image::FloatImage img = image::decode_exr(bytes);
    for (int y = 0; y < img.height; ++y) {
      for (int x = 0; x < img.width; ++x) {
        for (int ch = 0; ch < 3; ++ch) {
          const double expected = specular ? L[ch] : kPi * L[ch];
          // Both are sums of equal values under weights the bakers normalise, stored as float: measured 0 for the
          // specular levels and 3e-8 relative for the irradiance. 1e-5 relative is a few hundred float ulps of
          // room, while a wrong normalisation (a factor pi, 1/pi or 2) is off by orders of magnitude more.
          const double tolerance = 1e-5 * expected;
          ASSERT_NEAR(img.at(x, y, ch), expected, tolerance) << name << " (" << x << ", " << y << ") channel " << ch;
        }
      }
    }
  }
}

TEST(EnvironmentService, SixUploadedFacesKeepTheirOrder) {
  // Each face a different constant colour: the roughness-0 level (a mirror: the source itself, resampled) shows
  // each face's colour on the face of the same name, so the order +X, -X, +Y, -Y, +Z, -Z survives the whole path.
  Daemon d;
  Client c = connect(d);
  const float colours[6][3] = {{0.6f, 0.1f, 0.1f}, {0.1f, 0.6f, 0.1f}, {0.1f, 0.1f, 0.6f},
                               {0.5f, 0.5f, 0.1f}, {0.1f, 0.5f, 0.5f}, {0.5f, 0.1f, 0.5f}};
  v1::JobSpec spec = environment_job(v1::Digest());
  spec.mutable_environment()->mutable_faces();  // replaces the image in the oneof
  for (int f = 0; f < 6; ++f) {
    image::FloatImage face;
    face.width = face.height = 8;
    face.channels = 3;
    face.channel_names = {"R", "G", "B"};
    for (int i = 0; i < 64; ++i) face.pixels.insert(face.pixels.end(), colours[f], colours[f] + 3);
    *spec.mutable_environment()->mutable_faces()->add_digests() = c.upload_blob(image::encode_exr(face));
  }
  const v1::SubmitReply sub = c.submit(spec);
  const v1::JobEvent last = c.watch(sub.job_id());
  ASSERT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED) << last.message() << d.log();
  const auto outputs = fetch_and_check(c, c.result(sub.job_id()));
  const char* names[6] = {"px", "nx", "py", "ny", "pz", "nz"};
  for (int f = 0; f < 6; ++f) {
    const image::FloatImage img = image::decode_exr(outputs.at(std::string("specular_L0_") + names[f] + ".exr"));
    // A texel near the centre is interpolated inside one face only: its colour exactly, up to float rounding
    // (1e-5 relative, a few hundred ulps of room).
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(img.at(img.width / 2, img.height / 2, ch), colours[f][ch], 1e-5 * colours[f][ch])
          << names[f] << " channel " << ch;
    }
  }
}

TEST(EnvironmentService, ImagesTheDecoderRefusesFailTheJobWithItsMessage) {
  Daemon d;
  Client c = connect(d);
  struct Case {
    const char* what;
    std::string bytes;
    const char* fragment;  // of the decoder's message, for people
  };
  const std::vector<Case> cases = {
      {"not an image", "GIF89a these bytes are some other format entirely", "not an image"},
      // A Radiance HDR header claiming 100000 x 50000 pixels and no pixel data: refused from the header, before
      // anything that size is allocated.
      {"absurd size", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 50000 +X 100000\n" + std::string(16, '\0'), "100000"},
      {"not 2:1", image::encode_exr(sky_image(32, 32)), "2:1"},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.what);
    const v1::Error error = failure_of(c, environment_job(c.upload_blob(k.bytes)));
    EXPECT_EQ(error.code(), v1::Error::INVALID_ARGUMENT) << error.message();
    EXPECT_EQ(error.field(), "job.environment.image");
    EXPECT_NE(error.message().find(k.fragment), std::string::npos) << error.message();
  }
  // The daemon is still up and baking, and counts the failures.
  EXPECT_EQ(c.status().jobs_failed(), cases.size());
  const v1::SubmitReply ok = c.submit(environment_job(c.upload_blob(image::encode_exr(sky_image()))));
  EXPECT_EQ(c.watch(ok.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << d.log();
}

TEST(EnvironmentService, AMissingBlobIsRefusedAtSubmit) {
  Daemon d;
  Client c = connect(d);
  v1::Digest never_uploaded = client::digest_of("bytes this test never uploads");
  try {
    c.submit(environment_job(never_uploaded));
    FAIL() << "accepted a job naming a blob the server does not hold";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::INVALID_ARGUMENT);
    EXPECT_EQ(e.field(), "job.environment.image");
    EXPECT_NE(e.message().find("upload it"), std::string::npos) << e.message();
  }
}

TEST(EnvironmentService, NonFiniteAndNegativeTexelsAreReplacedAndCounted) {
  Daemon d;
  Client c = connect(d);
  image::FloatImage img = sky_image();
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  // 3 texels with a NaN channel, 2 with an infinite one (+Inf and -Inf), 4 with a negative one: each counted once.
  img.at(1, 1, 0) = nan;
  img.at(2, 1, 1) = nan;
  img.at(3, 20, 2) = nan;
  img.at(10, 5, 0) = inf;
  img.at(11, 25, 2) = -inf;
  for (int x = 30; x < 34; ++x) img.at(x, 10, 1) = -0.5f;
  const v1::SubmitReply sub = c.submit(environment_job(c.upload_blob(image::encode_exr(img))));
  ASSERT_EQ(c.watch(sub.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << d.log();
  const v1::JobResult r = c.result(sub.job_id());
  fetch_and_check(c, r);  // no NaN, Inf or negative value in any output EXR
  const std::string& json = r.report().json();
  // The report's layout is the JSON writer's: the counts are read back rather than matched as text.
  const nlohmann::json report = nlohmann::json::parse(json);
  ASSERT_TRUE(report.contains("sanitized")) << json;
  const nlohmann::json& m = report["sanitized"];
  EXPECT_EQ(m.value("nan", -1), 3);
  EXPECT_EQ(m.value("inf", -1), 2);
  EXPECT_EQ(m.value("negative", -1), 4);
  bool reported = false;
  for (const v1::PlanDecision& p : r.report().plan()) reported |= p.effect() == "sanitize";
  EXPECT_TRUE(reported) << "the plan names the replaced texels";
}

#ifdef KILN_BIN
// The command line: `kiln bake env IMAGE --out DIR` uploads, bakes and writes every output.
TEST(EnvironmentService, KilnBakeEnvWritesTheOutputs) {
  Daemon d;
  const std::filesystem::path sky = d.dir() / "sky.exr", out = d.dir() / "sky_env";
  {
    const std::string bytes = image::encode_exr(sky_image());
    std::ofstream(sky, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  const std::filesystem::path token = d.dir() / "cli-token";
  {
    std::ofstream t(token);
    t << d.token() << "\n";
  }
  const std::string command = std::string(KILN_BIN) + " --server " + d.tcp() + " --token-file " + token.string() +
                              " bake env " + sky.string() +
                              " --size 16 --irradiance-size 8 --dfg-size 8 "
                              "--dfg-samples 64 --samples 32 --out " +
                              out.string() + " 2>&1";
  const test::CommandResult run = test::run_command(command);
  const std::string& said = run.output;
  ASSERT_EQ(run.status, 0) << said;
  std::set<std::string> written;
  for (const auto& e : std::filesystem::directory_iterator(out)) written.insert(e.path().filename().string());
  std::set<std::string> expected = expected_names(3);
  if (written.count("preview.png")) expected.insert("preview.png");
  EXPECT_EQ(written, expected) << said;
}
#endif

}  // namespace
}  // namespace kiln
