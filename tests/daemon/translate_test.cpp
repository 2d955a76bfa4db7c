// The translation layer: job specs in protobuf text format become bakers inputs, and every bad field is refused
// with its path.
#include "daemon/translate.h"

#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "daemon/store/blob_store.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"
#include "tests/support/temp_dir.h"

namespace kiln::daemon {
namespace {

v1::JobSpec spec_from(const std::string& text) {
  v1::JobSpec spec;
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &spec)) << text;
  return spec;
}

TEST(Translate, GgxWithDefaults) {
  const BakeRequest r = translate(spec_from(R"(name: "x" material { ggx { alpha: 0.25 fresnel: FRESNEL_SCHLICK
                                                f0 { r: 0.04 g: 0.04 b: 0.04 } } })"));
  EXPECT_STREQ(job_type(r), "material");
  EXPECT_EQ(r.material().model.model, brdf::Model::ggx);
  EXPECT_EQ(r.material().model.alpha_x, 0.25);
  EXPECT_EQ(r.material().model.alpha_y, 0.25);
  EXPECT_EQ(brdf::fresnel_mode(r.material().model), brdf::FresnelMode::schlick);
  EXPECT_EQ(r.material().table_mu, 32);
  EXPECT_FALSE(r.material().merl);
}

TEST(Translate, EveryModelTranslates) {
  for (const char* text : {
           "material { lambert { albedo { r: 0.5 g: 0.5 b: 0.5 } } }",
           "material { oren_nayar { sigma: 0.3 interreflection: true } }",
           "material { oren_nayar_simple { sigma: 0.3 } }",
           "material { cook_torrance { alpha: 0.2 eta: 1.33 normalization: NORMALIZATION_PI } }",
           "material { beckmann { alpha_x: 0.1 alpha_y: 0.4 masking: MASKING_HEIGHT_CORRELATED } }",
           "material { schlick { r: 0.2 p: 0.5 } }",
           "material { schlick_double { top { r: 0.1 } bottom { r: 0.9 } } }",
       }) {
    EXPECT_NO_THROW(translate(spec_from(text))) << text;
  }
}

TEST(Translate, SameBakeSameKeyWhateverTheSpelling) {
  // Defaults spelled out or left out, and the name, do not change the key; any setting does.
  const auto a = translate(spec_from("name: \"a\" material { ggx { alpha: 0.3 } }"));
  const auto b = translate(spec_from("name: \"b\" material { ggx { alpha_x: 0.3 alpha_y: 0.3 } table_mu: 32 }"));
  const auto c = translate(spec_from("material { ggx { alpha: 0.31 } }"));
  EXPECT_EQ(cache_key(a, kBakerVersion), cache_key(b, kBakerVersion));
  EXPECT_NE(cache_key(a, kBakerVersion), cache_key(c, kBakerVersion));
  EXPECT_NE(cache_key(a, kBakerVersion), cache_key(a, "another-version"));
}

TEST(Translate, LayeredMaterialReachesTheBake) {
  const BakeRequest r = translate(spec_from(R"(material { layered {
      diffuse { oren_nayar { sigma: 0.3 albedo { r: 0.5 g: 0.4 b: 0.3 } } }
      specular { ggx { alpha: 0.2 fresnel: FRESNEL_SCHLICK } } } })"));
  ASSERT_TRUE(r.material().material.has_value());
  const brdf::MaterialSpec& m = *r.material().material;
  EXPECT_EQ(m.combine, brdf::Combine::layered);
  EXPECT_EQ(m.diffuse.model, brdf::Model::oren_nayar);
  EXPECT_EQ(m.diffuse.albedo.g, 0.4);
  EXPECT_EQ(m.specular.model, brdf::Model::ggx);
  EXPECT_EQ(m.specular.alpha_x, 0.2);
  const BakeRequest w = translate(
      spec_from("material { layered { combine: COMBINE_WEIGHTS specular_weight: 0.25 specular { ggx { } } } }"));
  EXPECT_EQ(w.material().material->combine, brdf::Combine::weights);
  EXPECT_EQ(w.material().material->specular_weight, 0.25);
}

TEST(Translate, EveryMaterialSettingChangesTheKey) {
  // Each of these differs from the others in one setting, so no two may share a key. preview was once left out of
  // the key, so a bake without preview.png answered a later request for one from the cache.
  std::set<std::string> keys;
  for (const char* text : {
           "material { ggx { } }",
           "material { ggx { } preview: false }",
           "material { layered { specular { ggx { } } } }",
           "material { layered { specular { ggx { alpha: 0.2 } } } }",
           "material { layered { specular { beckmann { } } } }",
           "material { layered { diffuse { lambert { albedo { r: 0.5 } } } specular { ggx { } } } }",
           "material { layered { combine: COMBINE_WEIGHTS specular { ggx { } } } }",
           "material { layered { combine: COMBINE_WEIGHTS specular_weight: 0.25 specular { ggx { } } } }",
       }) {
    const auto r = translate(spec_from(text));
    EXPECT_TRUE(keys.insert(cache_key(r, kBakerVersion)).second) << "same key as another: " << text;
  }
}

struct BadSpec {
  const char* text;
  const char* field;
  const char* problem;  // a fragment of the message
};

class TranslateRejects : public ::testing::TestWithParam<BadSpec> {};

TEST_P(TranslateRejects, NamingTheField) {
  try {
    translate(spec_from(GetParam().text));
    FAIL() << "accepted: " << GetParam().text;
  } catch (const InvalidField& e) {
    EXPECT_EQ(e.field(), GetParam().field) << e.what();
    EXPECT_NE(std::string(e.what()).find(GetParam().problem), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Table, TranslateRejects,
    ::testing::Values(
        BadSpec{"material { ggx { alpha: -0.2 } }", "job.material.ggx.alpha", "must be in (0, 1], got -0.2"},
        BadSpec{"material { ggx { alpha: 0 } }", "job.material.ggx.alpha", "must be in (0, 1]"},
        BadSpec{"material { ggx { alpha: nan } }", "job.material.ggx.alpha", "got nan"},
        BadSpec{"material { ggx { alpha: inf } }", "job.material.ggx.alpha", "got inf"},
        BadSpec{"material { ggx { alpha: 0.3 alpha_x: 0.2 alpha_y: 0.2 } }", "job.material.ggx.alpha", "not both"},
        BadSpec{"material { ggx { alpha_x: 0.2 } }", "job.material.ggx.alpha_y", "go together"},
        BadSpec{"material { beckmann { alpha_x: 0.2 alpha_y: 2 } }", "job.material.beckmann.alpha_y", "got 2"},
        BadSpec{"material { ggx { f0 { r: 1.5 } } }", "job.material.ggx.f0.r", "got 1.5"},
        BadSpec{"material { ggx { f0 { g: -1 } } }", "job.material.ggx.f0.g", "got -1"},
        BadSpec{"material { cook_torrance { eta: 0.01 } }", "job.material.cook_torrance.eta", "[0.1, 10]"},
        BadSpec{"material { cook_torrance { eta: 11 } }", "job.material.cook_torrance.eta", "got 11"},
        BadSpec{"material { lambert { albedo { b: 2 } } }", "job.material.lambert.albedo.b", "got 2"},
        BadSpec{"material { oren_nayar { sigma: 2 } }", "job.material.oren_nayar.sigma", "got 2"},
        BadSpec{"material { oren_nayar { sigma: -0.1 } }", "job.material.oren_nayar.sigma", "got -0.1"},
        BadSpec{"material { oren_nayar_simple { interreflection: true } }",
                "job.material.oren_nayar_simple.interreflection", "full model"},
        BadSpec{"material { schlick { r: 1.1 } }", "job.material.schlick.r", "got 1.1"},
        BadSpec{"material { schlick { p: -0.5 } }", "job.material.schlick.p", "got -0.5"},
        BadSpec{"material { schlick { c { r: 3 } } }", "job.material.schlick.c.r", "got 3"},
        BadSpec{"material { schlick_double { bottom { r: 7 } } }", "job.material.schlick_double.bottom.r", "got 7"},
        BadSpec{"material { layered { specular { ggx { alpha: 2 } } } }", "job.material.layered.specular.ggx.alpha",
                "got 2"},
        BadSpec{"material { layered { specular_weight: 0.3 specular { ggx { } } } }",
                "job.material.layered.specular_weight", "COMBINE_WEIGHTS only"},
        BadSpec{"material { }", "job.material", "no model given"},
        BadSpec{"", "job", "no job given: set material, environment, lightmap or probes"},
        BadSpec{"material { ggx { } table_mu: 0 }", "job.material.table_mu", "got 0"},
        BadSpec{"material { ggx { } table_mu: 100000 }", "job.material.table_mu", "got 100000"},
        BadSpec{"material { ggx { } table_roughness: 1 }", "job.material.table_roughness", "got 1"},
        BadSpec{"quality { samples: 0 } material { ggx { } }", "job.quality.samples", "got 0"},
        BadSpec{"quality { samples: 99999999999 } material { ggx { } }", "job.quality.samples", "got"},
        BadSpec{"quality { target_error: 0 } material { ggx { } }", "job.quality.target_error", "(0, 1]"},
        BadSpec{"quality { target_error: -1 } material { ggx { } }", "job.quality.target_error", "got -1"},
        BadSpec{"quality { time_limit_seconds: 1e9 } material { ggx { } }", "job.quality.time_limit_seconds", "got"},
        BadSpec{"force_effects { key: \"volumes\" value: true } material { ggx { } }", "job.force_effects[volumes]",
                "unknown effect"}));

TEST(Translate, BoundsTheNameAndTheEffects) {
  v1::JobSpec spec = spec_from("material { ggx { } }");
  spec.set_name(std::string(257, 'n'));
  EXPECT_THROW(translate(spec), InvalidField);
  spec.set_name("ok");
  for (int i = 0; i < 65; ++i) (*spec.mutable_force_effects())["e" + std::to_string(i)] = true;
  try {
    translate(spec);
    FAIL();
  } catch (const InvalidField& e) {
    EXPECT_EQ(e.field(), "job.force_effects");
  }
}

TEST(Translate, ForcingMerlOverridesTheFlag) {
  EXPECT_TRUE(translate(spec_from("force_effects { key: \"merl\" value: true } material { ggx { } }")).material().merl);
  EXPECT_FALSE(translate(spec_from("force_effects { key: \"merl\" value: false } material { ggx { } merl: true }"))
                   .material()
                   .merl);
}

// ---- The environment job ----------------------------------------------------------------------------------------

// A well-formed digest (of bytes no store holds) for the form checks.
constexpr const char* kDigest =
    "sha256: \"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" size: 1000";

std::string faces_text(int n) {
  std::string t = "faces { ";
  for (int i = 0; i < n; ++i) t += std::string("digests { ") + kDigest + " } ";
  return t + "}";
}

TEST(TranslateEnvironment, EveryFieldReachesTheBakersInput) {
  const BakeRequest r = translate(spec_from(std::string(R"(
      name: "sky" quality { samples: 256 target_error: 0.02 seed: 7 }
      force_effects { key: "sun_light" value: false }
      environment { image { )") + kDigest + R"( } color_space: "lin_rec709" rotation_degrees: -90 intensity: 2.5
                    lobe: ENVIRONMENT_LOBE_BECKMANN size: 64 levels: 3 irradiance_size: 16 dfg_size: 32
                    dfg_samples: 64 preview: false dfg_masking: MASKING_SEPARABLE })"));
  EXPECT_STREQ(job_type(r), "environment");
  const envmap::EnvironmentBakeInput& in = r.environment();
  EXPECT_FALSE(in.constant.has_value());
  EXPECT_TRUE(in.image.empty());  // the bytes come with load_inputs
  ASSERT_EQ(r.inputs.size(), 1u);
  EXPECT_EQ(r.inputs[0].field, "job.environment.image");
  EXPECT_EQ(r.inputs[0].size, 1000u);
  EXPECT_EQ(in.decode.color_space, "lin_rec709");
  EXPECT_EQ(in.decode.rotation_degrees, -90);
  EXPECT_EQ(in.decode.intensity, 2.5);
  EXPECT_EQ(in.lobe, envmap::EnvLobe::beckmann);
  EXPECT_EQ(in.size, 64);
  EXPECT_EQ(in.levels, 3);
  EXPECT_EQ(in.irradiance_size, 16);
  EXPECT_EQ(in.dfg_size, 32);
  EXPECT_EQ(in.dfg_samples, 64);
  EXPECT_EQ(in.dfg_masking, brdf::Masking::separable);
  EXPECT_FALSE(in.preview);
  EXPECT_EQ(in.samples, 256);
  EXPECT_EQ(in.target_error, 0.02);
  EXPECT_EQ(in.seed, 7u);
  EXPECT_EQ(in.force_effects, (std::map<std::string, bool>{{"sun_light", false}}));
  EXPECT_STREQ(baker_version(r), envmap::kEnvironmentBakerVersion);
}

TEST(TranslateEnvironment, DefaultsAreTheBakers) {
  const BakeRequest r = translate(spec_from("environment { constant { r: 0.5 g: 1 b: 2 } }"));
  const envmap::EnvironmentBakeInput defaults;
  EXPECT_EQ(r.environment().constant->r, 0.5);
  EXPECT_EQ(r.environment().constant->b, 2.0);
  EXPECT_TRUE(r.inputs.empty());
  EXPECT_EQ(r.environment().size, defaults.size);
  EXPECT_EQ(r.environment().levels, defaults.levels);
  EXPECT_EQ(r.environment().samples, defaults.samples);
  EXPECT_EQ(r.environment().target_error, defaults.target_error);
  EXPECT_EQ(r.environment().preview, defaults.preview);
  EXPECT_EQ(r.environment().lobe, envmap::EnvLobe::ggx);
  EXPECT_FALSE(r.environment().dfg_masking.has_value());  // the lobe's own: height-correlated for ggx
  const BakeRequest faces = translate(spec_from("environment { " + faces_text(6) + " }"));
  ASSERT_EQ(faces.inputs.size(), 6u);
  EXPECT_EQ(faces.inputs[5].field, "job.environment.faces.digests[5]");
}

TEST(TranslateEnvironment, SameBakeSameKeyAndEverySettingChangesIt) {
  const std::string image = std::string("image { ") + kDigest + " }";
  // Defaults spelled out (levels 6 is every level of a 128 cube down to 4x4) or left out, and the name: one key.
  const auto a = translate(spec_from("name: \"a\" environment { " + image + " }"));
  const auto b = translate(spec_from("name: \"b\" environment { " + image +
                                     " size: 128 levels: 6 lobe: ENVIRONMENT_LOBE_GGX intensity: 1 preview: true"
                                     " dfg_masking: MASKING_HEIGHT_CORRELATED }"
                                     " quality { target_error: 0.01 }"));
  EXPECT_EQ(cache_key(a, baker_version(a)), cache_key(b, baker_version(b))) << canonical_text(a) << canonical_text(b);
  std::set<std::string> keys{cache_key(a, baker_version(a))};
  const std::string other_digest =
      "image { sha256: \"1123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" size: 1000 }";
  for (const std::string& text : {
           "environment { " + other_digest + " }",
           std::string(
               "environment { image { sha256: \"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\""
               " size: 1001 } }"),
           "environment { " + faces_text(6) + " }",
           std::string("environment { constant { r: 1 g: 1 b: 1 } }"),
           "environment { " + image + " color_space: \"srgb_texture\" }",
           "environment { " + image + " rotation_degrees: 10 }",
           "environment { " + image + " intensity: 2 }",
           "environment { " + image + " lobe: ENVIRONMENT_LOBE_SCHLICK }",
           "environment { " + image + " size: 64 }",
           "environment { " + image + " levels: 2 }",
           "environment { " + image + " irradiance_size: 8 }",
           "environment { " + image + " dfg_size: 16 }",
           "environment { " + image + " dfg_samples: 32 }",
           "environment { " + image + " dfg_masking: MASKING_SEPARABLE }",
           "environment { " + image + " preview: false }",
           "quality { samples: 64 } environment { " + image + " }",
           "quality { target_error: 0.05 } environment { " + image + " }",
           "quality { seed: 3 } environment { " + image + " }",
           "force_effects { key: \"sun_light\" value: true } environment { " + image + " }",
       }) {
    const auto r = translate(spec_from(text));
    EXPECT_TRUE(keys.insert(cache_key(r, baker_version(r))).second) << "same key as another: " << text;
  }
  // The material and environment bakers version their keys separately.
  EXPECT_NE(cache_key(a, envmap::kEnvironmentBakerVersion), cache_key(a, "kiln-environment-0"));
}

#define IMAGE "image { sha256: \"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" size: 1000 } "
INSTANTIATE_TEST_SUITE_P(
    Environment, TranslateRejects,
    ::testing::Values(
        BadSpec{"environment { }", "job.environment", "no environment given"},
        BadSpec{"environment { image { sha256: \"abc\" size: 10 } }", "job.environment.image.sha256", "64 lowercase"},
        BadSpec{"environment { image { sha256: \"0123456789ABCDEF0123456789abcdef0123456789abcdef0123456789abcdef\" "
                "size: 10 } }",
                "job.environment.image.sha256", "64 lowercase"},
        BadSpec{
            "environment { image { sha256: \"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" } }",
            "job.environment.image.size", "0 bytes"},
        BadSpec{"environment { image { sha256: \"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" "
                "size: 536870913 } }",
                "job.environment.image.size", "at most 512 MiB"},
        BadSpec{"environment { faces { } }", "job.environment.faces.digests", "exactly six faces"},
        BadSpec{"environment { faces { digests { } digests { } digests { } digests { } digests { } } }",
                "job.environment.faces.digests", "got 5"},
        BadSpec{
            "environment { faces { digests {} digests {} digests {} digests {} digests {} digests {} digests {} } }",
            "job.environment.faces.digests", "got 7"},
        BadSpec{"environment { faces { digests { sha256: "
                "\"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" "
                "size: 5 } digests {} digests {} digests {} digests {} digests {} } }",
                "job.environment.faces.digests[1].sha256", "64 lowercase"},
        BadSpec{"environment { constant { r: -1 } }", "job.environment.constant.r", "got -1"},
        BadSpec{"environment { constant { g: 2e6 } }", "job.environment.constant.g", "got 2e+06"},
        BadSpec{"environment { constant { b: nan } }", "job.environment.constant.b", "got nan"},
        BadSpec{"environment { constant { r: 1 } intensity: 2 }", "job.environment.intensity", "constant colour"},
        BadSpec{"environment { constant { r: 1 } rotation_degrees: 2 }", "job.environment.rotation_degrees",
                "constant colour"},
        BadSpec{"environment { constant { r: 1 } color_space: \"srgb_texture\" }", "job.environment.color_space",
                "constant colour"},
        BadSpec{"environment { " IMAGE "color_space: \"no_such_space\" }", "job.environment.color_space",
                "'no_such_space' is not a colour space"},
        BadSpec{"environment { " IMAGE "rotation_degrees: 400 }", "job.environment.rotation_degrees", "got 400"},
        BadSpec{"environment { " IMAGE "rotation_degrees: inf }", "job.environment.rotation_degrees", "got inf"},
        BadSpec{"environment { " IMAGE "intensity: 0 }", "job.environment.intensity", "must be in (0, 1e+06], got 0"},
        BadSpec{"environment { " IMAGE "intensity: -1 }", "job.environment.intensity", "got -1"},
        BadSpec{"environment { " IMAGE "lobe: 9 }", "job.environment.lobe", "unknown value 9"},
        BadSpec{"environment { " IMAGE "dfg_masking: 9 }", "job.environment.dfg_masking", "unknown value 9"},
        BadSpec{"environment { " IMAGE "dfg_masking: MASKING_V_GROOVE }", "job.environment.dfg_masking",
                "must be separable or height-correlated for the ggx lobe, got v-groove"},
        BadSpec{"environment { " IMAGE "lobe: ENVIRONMENT_LOBE_COOK_TORRANCE dfg_masking: MASKING_SEPARABLE }",
                "job.environment.dfg_masking", "cook_torrance's DFG table uses its own V-groove masking"},
        BadSpec{"environment { " IMAGE "size: 100 }", "job.environment.size", "power of two"},
        BadSpec{"environment { " IMAGE "size: 2 }", "job.environment.size", "got 2"},
        BadSpec{"environment { " IMAGE "size: 4096 }", "job.environment.size", "got 4096"},
        BadSpec{"environment { " IMAGE "size: 16 levels: 4 }", "job.environment.levels", "[1, 3], got 4"},
        BadSpec{"environment { " IMAGE "levels: 0 }", "job.environment.levels", "got 0"},
        BadSpec{"environment { " IMAGE "irradiance_size: 0 }", "job.environment.irradiance_size", "got 0"},
        BadSpec{"environment { " IMAGE "irradiance_size: 257 }", "job.environment.irradiance_size", "got 257"},
        BadSpec{"environment { " IMAGE "dfg_size: 1 }", "job.environment.dfg_size", "got 1"},
        BadSpec{"environment { " IMAGE "dfg_size: 2000 }", "job.environment.dfg_size", "got 2000"},
        BadSpec{"environment { " IMAGE "dfg_samples: 8 }", "job.environment.dfg_samples", "got 8"},
        BadSpec{"environment { " IMAGE "dfg_samples: 2000000 }", "job.environment.dfg_samples",
                "[16, 1048576], got 2e+06"},
        BadSpec{"quality { samples: 2 } environment { " IMAGE "}", "job.quality.samples", "[4, 65536], got 2"},
        BadSpec{"quality { samples: 100000 } environment { " IMAGE "}", "job.quality.samples", "got 100000"},
        BadSpec{"quality { target_error: 0.00001 } environment { " IMAGE "}", "job.quality.target_error", "got 1e-05"},
        BadSpec{"quality { target_error: 2 } environment { " IMAGE "}", "job.quality.target_error", "got 2"},
        BadSpec{"quality { time_limit_seconds: 10 } environment { " IMAGE "}", "job.quality.time_limit_seconds",
                "not supported"},
        BadSpec{"force_effects { key: \"\" value: true } environment { " IMAGE "}", "job.force_effects[]",
                "1 to 64 bytes"},
        BadSpec{"force_effects { key: \"a_name_that_is_much_longer_than_sixty_four_bytes_which_is_the_limit_here\" "
                "value: true } environment { " IMAGE "}",
                "job.force_effects[a_name_that_is_much_longer_than_sixty_four_bytes_which_is_the_li]",
                "1 to 64 bytes, got 72"},
        BadSpec{"force_effects { key: \"volumes\" value: true } environment { " IMAGE "}", "job.force_effects[volumes]",
                "unknown effect 'volumes'"}));
#undef IMAGE

TEST(TranslateEnvironment, TwoSourcesCannotBeWritten) {
  // The source is a oneof: a job file naming two is refused by the text parser, before any server sees it
  // (on the wire the last one written wins, as protobuf defines for a oneof).
  v1::JobSpec spec;
  EXPECT_FALSE(google::protobuf::TextFormat::ParseFromString(
      std::string("environment { constant { r: 1 } ") + "image { " + kDigest + " } }", &spec));
}

TEST(TranslateEnvironment, InputBlobsMustBeInTheStoreAndAreReadFromIt) {
  test::TempDir dir;
  store::BlobStore blobs(dir.path() / "store");
  const std::string bytes = "these bytes stand for an image; translate does not decode";
  const store::BlobId id = blobs.put(bytes);
  v1::JobSpec spec;
  spec.mutable_environment()->mutable_image()->set_sha256(id.digest);
  spec.mutable_environment()->mutable_image()->set_size(id.size);
  BakeRequest r = translate(spec, &blobs);
  load_inputs(r, blobs);
  EXPECT_EQ(r.environment().image, bytes);

  // A digest the store does not hold, or holds with another size: refused at submit, naming the field.
  for (uint64_t size : {id.size + 1, id.size}) {
    v1::JobSpec missing = spec;
    if (size == id.size) missing.mutable_environment()->mutable_image()->set_sha256(proto::sha256_hex("other"));
    missing.mutable_environment()->mutable_image()->set_size(size);
    try {
      translate(missing, &blobs);
      FAIL() << "accepted a blob the store does not hold";
    } catch (const InvalidField& e) {
      EXPECT_EQ(e.field(), "job.environment.image");
      EXPECT_NE(std::string(e.what()).find("upload it"), std::string::npos) << e.what();
    }
  }
  // Six faces, read in their order.
  v1::JobSpec faces;
  std::vector<std::string> face_bytes;
  for (int i = 0; i < 6; ++i) {
    face_bytes.push_back("face " + std::to_string(i));
    const store::BlobId f = blobs.put(face_bytes.back());
    auto* d = faces.mutable_environment()->mutable_faces()->add_digests();
    d->set_sha256(f.digest);
    d->set_size(f.size);
  }
  BakeRequest rf = translate(faces, &blobs);
  load_inputs(rf, blobs);
  EXPECT_EQ(rf.environment().faces, face_bytes);
}

TEST(TranslateEnvironment, BakerComplaintsNameTheJobsField) {
  const BakeRequest image = translate(spec_from(std::string("environment { image { ") + kDigest + " } }"));
  // Bytes that do not decode: the image's field, the baker's message.
  const InvalidField undecodable = input_error(image, std::runtime_error("not an image: the bytes start with 'GIF8'"));
  EXPECT_EQ(undecodable.field(), "job.environment.image");
  EXPECT_EQ(std::string(undecodable.what()), "job.environment.image: not an image: the bytes start with 'GIF8'");
  // A baker's "field: problem".
  EXPECT_EQ(input_error(image, bake::InvalidInput("size", "must be a power of two")).field(), "job.environment.size");
  const BakeRequest faces = translate(spec_from("environment { " + faces_text(6) + " }"));
  EXPECT_EQ(input_error(faces, std::runtime_error("face 3 is not square")).field(), "job.environment.faces");
}

}  // namespace
}  // namespace kiln::daemon
