// A layered (two-lobe) material end to end: the real kilnd bakes it from a job spec and from `kiln bake material`'s
// lobe flags; its white-furnace test, its MERL table and its report come back through the service.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <google/protobuf/text_format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include "bakers/brdf/material.h"
#include "bakers/image/exr.h"
#include "bakers/material/material_bake.h"
#include "bakers/material/merl.h"
#include "bakers/math/constants.h"
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

// A red Lambertian base under a clear GGX coat, small tables, with MERL.
constexpr const char* kLayeredJob = R"(
  name: "layered plastic"
  material {
    layered {
      diffuse { lambert { albedo { r: 0.6 g: 0.1 b: 0.05 } } }
      specular { ggx { alpha: 0.2 fresnel: FRESNEL_SCHLICK f0 { r: 0.04 g: 0.04 b: 0.04 } } }
    }
    table_mu: 8
    table_roughness: 4
    merl: true
    preview: false
  }
  quality { samples: 4096 seed: 1 })";

// The same material in the bakers' own words.
brdf::MaterialSpec layered_plastic() {
  brdf::MaterialSpec m;
  m.diffuse.model = brdf::Model::lambert;
  m.diffuse.albedo = Rgb{0.6, 0.1, 0.05};
  m.specular.model = brdf::Model::ggx;
  m.specular.alpha_x = m.specular.alpha_y = 0.2;
  m.specular.fresnel = brdf::FresnelMode::schlick;
  m.specular.f0 = Rgb{0.04};
  m.combine = brdf::Combine::layered;
  return m;
}

std::map<std::string, std::string> fetch_all(Client& c, const v1::JobResult& r) {
  std::map<std::string, std::string> out;
  for (const v1::Output& o : r.outputs()) {
    out[o.name()] = c.fetch(o.digest());
    EXPECT_EQ(proto::sha256_hex(out[o.name()]), o.digest().sha256()) << o.name();
  }
  return out;
}

TEST(MaterialService, ALayeredMaterialBakesWithItsFurnaceTestAndMerlTable) {
  Daemon d;
  Client c = connect(d);
  v1::JobSpec spec;
  ASSERT_TRUE(google::protobuf::TextFormat::ParseFromString(kLayeredJob, &spec));
  const v1::SubmitReply sub = c.submit(spec);
  const v1::JobEvent last = c.watch(sub.job_id());
  ASSERT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED) << last.message() << d.log();
  const v1::JobResult r = c.result(sub.job_id());
  EXPECT_EQ(r.report().baker_version(), material::kMaterialBakerVersion);
  const auto outputs = fetch_all(c, r);
  std::set<std::string> names;
  for (const auto& [name, bytes] : outputs) names.insert(name);
  EXPECT_EQ(names, (std::set<std::string>{"albedo.exr", "split_sum.exr", "brdf.merl", "report.json"}));

  // The furnace test: the white form (both lobes white, Fresnel off) reflects at most what it receives at every μ,
  // within 3 of its standard errors, as the report says.
  const auto report = nlohmann::json::parse(outputs.at("report.json"));
  EXPECT_EQ(report["model"]["name"], "material");
  EXPECT_EQ(report["model"]["combine"], "layered");
  EXPECT_EQ(report["model"]["diffuse"], "lambert");
  EXPECT_EQ(report["model"]["specular"], "ggx");
  EXPECT_TRUE(report["validation"]["energy"]["conserves_energy"].get<bool>());
  const image::FloatImage albedo = image::decode_exr(outputs.at("albedo.exr"));
  ASSERT_EQ(albedo.width, 8);
  const int white = albedo.channel_index("white"), white_err = albedo.channel_index("white_err");
  for (int x = 0; x < albedo.width; ++x) {
    EXPECT_LE(albedo.at(x, 0, white), 1.0 + 3 * albedo.at(x, 0, white_err) + 1e-6) << "mu texel " << x;
    // It keeps most: the coat's light reflected back down is the only loss (docs/BRDF.md, 4-8 % at f0 = 0.04).
    EXPECT_GT(albedo.at(x, 0, white), 0.8) << "mu texel " << x;
  }
  // Reciprocal to rounding: both orders multiply the same numbers.
  EXPECT_LT(report["validation"]["reciprocity"]["max_relative_difference"].get<double>(), 1e-12);

  // The MERL table holds the layered model at cell centres (merl.h): the library's brdf::Material, evaluated here.
  const material::MerlTable table = material::decode_merl(outputs.at("brdf.merl"));
  const brdf::Material model(layered_plastic());
  int checked = 0;
  for (int i_h = 5; i_h < material::kMerlThetaH; i_h += 17) {
    for (int i_d = 3; i_d < material::kMerlThetaD; i_d += 19) {
      const double th = std::pow((i_h + 0.5) / material::kMerlThetaH, 2) * kPi / 2;
      const double td = (i_d + 0.5) / material::kMerlThetaD * kPi / 2;
      const material::MerlDirections w = material::merl_directions(th, td, 0.5 / material::kMerlPhiD * kPi);
      if (w.wo.z <= 0 || w.wi.z <= 0) continue;
      const Rgb f = model.eval(w.wo, w.wi), g = table.at(i_h, i_d, 0);
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(g[ch], f[ch], 1e-12 * f[ch]) << i_h << " " << i_d << " " << ch;
      ++checked;
    }
  }
  EXPECT_GT(checked, 10);

  // The same bake under another name is a cache hit; another combination is another bake.
  v1::JobSpec again = spec;
  again.set_name("same plastic");
  EXPECT_TRUE(c.submit(again).cache_hit());
  v1::JobSpec weights = spec;
  weights.mutable_material()->mutable_layered()->set_combine(v1::COMBINE_WEIGHTS);
  EXPECT_FALSE(c.submit(weights).cache_hit());
}

#ifdef KILN_BIN
// `kiln bake material --diffuse ... --specular ...` bakes the same material and writes its outputs; a bad lobe
// parameter is refused naming the flag the user typed.
TEST(MaterialService, KilnBakeMaterialTakesTheLobeFlags) {
  Daemon d;
  const std::filesystem::path token = d.dir() / "cli-token", out = d.dir() / "layered";
  {
    std::ofstream t(token);
    t << d.token() << "\n";
  }
  const std::string kiln = std::string(KILN_BIN) + " --server " + d.tcp() + " --token-file " + token.string();
  const test::CommandResult run = test::run_command(
      kiln +
      " bake material --diffuse lambert --diffuse-albedo 0.6,0.1,0.05 --specular ggx --specular-alpha 0.2 "
      "--specular-fresnel schlick --specular-f0 0.04 --table-mu 8 --table-roughness 4 --samples 1024 --no-preview "
      "--out " +
      out.string() + " 2>&1");
  ASSERT_EQ(run.status, 0) << run.output;
  std::set<std::string> written;
  for (const auto& e : std::filesystem::directory_iterator(out)) written.insert(e.path().filename().string());
  EXPECT_EQ(written, (std::set<std::string>{"albedo.exr", "split_sum.exr", "report.json"})) << run.output;
  std::ifstream f(out / "report.json");
  const auto report = nlohmann::json::parse(f);
  EXPECT_EQ(report["model"]["combine"], "layered");
  EXPECT_TRUE(report["validation"]["energy"]["conserves_energy"].get<bool>());

  const test::CommandResult bad = test::run_command(
      kiln + " bake material --diffuse lambert --specular ggx --specular-alpha 0.2 --specular-f0 0.04 --out " +
      (d.dir() / "bad").string() + " 2>&1");
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("--specular-f0"), std::string::npos) << bad.output;
}
#endif

}  // namespace
}  // namespace kiln
