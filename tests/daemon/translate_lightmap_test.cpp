// The lightmap job's translation: a job that sets every field maps each onto the baker's input; bad fields are
// refused naming their path; mesh blobs decode to the layout kiln.proto documents (the test writes the bytes by hand
// from that description, independently of the client's encoder) and malformed ones are refused; the cache key
// follows the settings and the blobs and nothing else.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "bakers/plan/lightmap_plan.h"
#include "daemon/mesh_blob_decode.h"
#include "daemon/translate.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {
namespace {

v1::Digest digest(char fill, uint64_t size = 1000) {
  v1::Digest d;
  d.set_sha256(std::string(64, fill));
  d.set_size(size);
  return d;
}

void set(v1::Vector3* v, double x, double y, double z) {
  v->set_x(x);
  v->set_y(y);
  v->set_z(z);
}

void set(v1::Color* c, double r, double g, double b) {
  c->set_r(r);
  c->set_g(g);
  c->set_b(b);
}

// A job that sets every field of LightmapJob.
v1::JobSpec full_job() {
  v1::JobSpec spec;
  spec.set_name("test scene");
  v1::LightmapJob* j = spec.mutable_lightmap();
  for (const char* name : {"floor", "box"}) {
    v1::Mesh* m = j->add_meshes();
    m->set_name(name);
    *m->mutable_geometry() = digest(name[0] == 'f' ? 'a' : 'b');
  }
  v1::Instance* i0 = j->add_instances();
  i0->set_mesh(0);
  v1::Instance* i1 = j->add_instances();
  i1->set_mesh(1);
  for (double v : {2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 2.0, 3.0}) i1->add_transform(v);
  i1->set_lightmap("atlas");
  for (double v : {0.5, 0.5, 0.25, 0.0}) i1->add_lightmap_scale_offset(v);
  v1::Instance* i2 = j->add_instances();
  i2->set_mesh(1);
  i2->set_bake(false);
  v1::Texture* t = j->add_textures();
  t->set_name("bricks.png");
  *t->mutable_image() = digest('c');
  t->set_color_space("srgb_texture");
  v1::SceneMaterial* white = j->add_materials();
  white->set_name("white");
  set(white->mutable_base_color(), 0.7, 0.6, 0.5);
  white->set_base_color_texture(0);
  white->set_two_sided(true);
  v1::SceneMaterial* lamp = j->add_materials();
  lamp->set_name("lamp");
  set(lamp->mutable_emission(), 17, 12, 4);
  v1::MaterialOverride* o = j->add_material_overrides();
  o->set_name("white");
  o->mutable_bsdf()->mutable_diffuse()->mutable_oren_nayar()->set_sigma(0.3);
  o->mutable_bsdf()->mutable_specular()->mutable_ggx()->set_alpha(0.2);
  set(o->mutable_base_color(), 0.25, 0.5, 0.75);
  v1::Light* point = j->add_lights();
  point->set_name("bulb");
  set(point->mutable_color(), 10, 20, 30);
  set(point->mutable_point()->mutable_position(), 1, 2, 3);
  v1::Light* spot = j->add_lights();
  set(spot->mutable_spot()->mutable_position(), 0, 3, 0);
  set(spot->mutable_spot()->mutable_direction(), 0, -2, 0);
  spot->mutable_spot()->set_inner_cone_angle(0.2);
  spot->mutable_spot()->set_outer_cone_angle(0.5);
  v1::Light* sun = j->add_lights();
  set(sun->mutable_directional()->mutable_direction(), 0, 0, -3);
  sun->mutable_directional()->set_angular_diameter(0.02);
  v1::Light* rect = j->add_lights();
  set(rect->mutable_rect()->mutable_center(), 0, 2, 0);
  set(rect->mutable_rect()->mutable_u(), 1, 0, 0);
  set(rect->mutable_rect()->mutable_v(), 0, 0, 2);
  rect->mutable_rect()->set_two_sided(true);
  v1::Light* disk = j->add_lights();
  set(disk->mutable_disk()->mutable_center(), 0, 2, 0);
  set(disk->mutable_disk()->mutable_normal(), 0, -1, 0);
  disk->mutable_disk()->set_radius(0.5);
  v1::SceneEnvironment* env = j->mutable_environment();
  *env->mutable_image() = digest('d');
  env->set_color_space("lin_rec709");
  env->set_rotation_degrees(90);
  env->set_intensity(2);
  j->set_resolution(32);
  v1::LightmapSettings* l = j->add_lightmaps();
  l->set_name("atlas");
  l->set_resolution(64);
  j->set_padding(2);
  j->set_max_bounces(5);
  j->set_radiance(true);
  j->set_ao(true);
  j->set_directional(true);
  j->set_preview(false);
  j->set_denoise(true);
  j->set_stitch_seams(false);
  j->set_error_metric(v1::LIGHTMAP_ERROR_METRIC_TEXEL);
  j->set_generate_uvs(v1::GENERATE_UVS_ALWAYS);
  spec.mutable_quality()->set_samples(256);
  spec.mutable_quality()->set_target_error(0.05);
  spec.mutable_quality()->set_time_limit_seconds(30);
  spec.mutable_quality()->set_seed(7);
  (*spec.mutable_force_effects())[plan::lightmap_effect_names().front()] = false;
  return spec;
}

TEST(TranslateLightmap, EveryFieldMapsOntoTheBakersInput) {
  const BakeRequest r = translate(full_job());
  EXPECT_STREQ(job_type(r), "lightmap");
  EXPECT_EQ(r.name, "test scene");
  const lightmap::LightmapBakeInput& in = r.lightmap();
  const scene::Scene& s = in.scene;
  ASSERT_EQ(s.meshes.size(), 2u);
  EXPECT_EQ(s.meshes[0].name, "floor");
  EXPECT_TRUE(s.meshes[0].positions.empty());  // decoded by load_inputs, in the worker
  ASSERT_EQ(s.instances.size(), 3u);
  EXPECT_EQ(s.instances[1].mesh, 1);
  EXPECT_EQ(s.instances[1].to_world.m[3], 1.0);
  EXPECT_EQ(s.instances[1].to_world.m[11], 3.0);
  EXPECT_EQ(s.instances[1].lightmap, "atlas");
  EXPECT_EQ(s.instances[1].lightmap_scale_offset[2], 0.25);
  EXPECT_TRUE(s.instances[0].bake);
  EXPECT_FALSE(s.instances[2].bake);
  ASSERT_EQ(in.textures.size(), 1u);
  EXPECT_EQ(in.textures[0].name, "bricks.png");
  EXPECT_EQ(in.textures[0].color_space, "srgb_texture");
  ASSERT_EQ(s.materials.size(), 2u);
  // The override replaced the BSDF and the base colour, and kept the rest.
  EXPECT_EQ(s.materials[0].bsdf.diffuse.model, brdf::Model::oren_nayar);
  EXPECT_EQ(s.materials[0].bsdf.diffuse.sigma, 0.3);
  EXPECT_EQ(s.materials[0].bsdf.specular.model, brdf::Model::ggx);
  EXPECT_EQ(s.materials[0].base_color.g, 0.5);
  EXPECT_EQ(s.materials[0].base_color_texture, 0);
  EXPECT_TRUE(s.materials[0].two_sided);
  EXPECT_EQ(s.materials[1].emission.r, 17);
  EXPECT_EQ(s.materials[1].bsdf.diffuse.model, brdf::Model::lambert);  // the default material
  ASSERT_EQ(s.lights.size(), 5u);
  EXPECT_EQ(s.lights[0].type, scene::LightShape::point);
  EXPECT_EQ(s.lights[0].name, "bulb");
  EXPECT_EQ(s.lights[0].color.b, 30);
  EXPECT_EQ(s.lights[0].position.z, 3);
  EXPECT_EQ(s.lights[1].type, scene::LightShape::spot);
  EXPECT_EQ(s.lights[1].direction.y, -1);  // normalised
  EXPECT_EQ(s.lights[1].inner_cone, 0.2);
  EXPECT_EQ(s.lights[1].outer_cone, 0.5);
  EXPECT_EQ(s.lights[2].type, scene::LightShape::directional);
  EXPECT_EQ(s.lights[2].direction.z, -1);
  EXPECT_EQ(s.lights[2].angular_diameter, 0.02);
  EXPECT_EQ(s.lights[3].type, scene::LightShape::rect);
  EXPECT_EQ(s.lights[3].v_axis.z, 2);
  // u × v = x × 2z = −2y: the emitting side faces −y.
  EXPECT_EQ(s.lights[3].direction.y, -1);
  EXPECT_TRUE(s.lights[3].two_sided);
  EXPECT_EQ(s.lights[4].type, scene::LightShape::disk);
  EXPECT_EQ(s.lights[4].radius, 0.5);
  EXPECT_EQ(in.environment_decode.color_space, "lin_rec709");
  EXPECT_EQ(in.environment_decode.rotation_degrees, 90);
  EXPECT_EQ(in.environment_decode.intensity, 2);
  EXPECT_EQ(in.resolution, 32);
  EXPECT_EQ(in.resolutions.at("atlas"), 64);
  EXPECT_EQ(in.padding, 2);
  EXPECT_EQ(in.max_bounces, 5);
  EXPECT_TRUE(in.radiance && in.ao && in.directional && in.denoise);
  EXPECT_EQ(in.error_metric, lightmap::ErrorMetric::texel);
  EXPECT_EQ(in.generate_uvs, uvgen::GenerateUvs::always);
  EXPECT_FALSE(in.preview);
  EXPECT_FALSE(in.stitch_seams);
  EXPECT_EQ(in.max_samples, 256u);
  EXPECT_EQ(in.min_samples, 16u);
  EXPECT_EQ(in.target_error, 0.05);
  EXPECT_EQ(in.time_limit_seconds, 30);
  EXPECT_EQ(in.seed, 7u);
  EXPECT_EQ(in.force_effects.size(), 1u);
  // Blobs in field order: meshes, textures, environment.
  ASSERT_EQ(r.inputs.size(), 4u);
  EXPECT_EQ(r.inputs[0].field, "job.lightmap.meshes[0].geometry");
  EXPECT_EQ(r.inputs[2].field, "job.lightmap.textures[0].image");
  EXPECT_EQ(r.inputs[3].field, "job.lightmap.environment.image");
  EXPECT_EQ(std::string(baker_version(r)), lightmap::kLightmapBakerVersion);
}

TEST(TranslateLightmap, BakerComplaintsNameTheJobsFieldByTheirField) {
  const BakeRequest r = translate(full_job());
  // Bytes that do not decode: the blob's field, the baker's problem.
  const InvalidField texture = input_error(r, bake::InvalidInput("textures[0]", "not an image"));
  EXPECT_EQ(texture.field(), "job.lightmap.textures[0].image");
  EXPECT_EQ(std::string(texture.what()), "job.lightmap.textures[0].image: not an image");
  EXPECT_EQ(input_error(r, bake::InvalidInput("environment_image", "not an image")).field(),
            "job.lightmap.environment.image");
  // Nothing to bake: the whole job.
  const InvalidField nothing = input_error(r, bake::InvalidInput("", "nothing to bake"));
  EXPECT_EQ(nothing.field(), "job.lightmap");
  EXPECT_EQ(std::string(nothing.what()), "job.lightmap: nothing to bake");
  // A setting the baker refuses, under the job.
  EXPECT_EQ(input_error(r, bake::InvalidInput("padding", "too wide")).field(), "job.lightmap.padding");
}

TEST(TranslateLightmap, DefaultsAreTheDocumentedOnes) {
  v1::JobSpec spec;
  v1::Mesh* m = spec.mutable_lightmap()->add_meshes();
  m->set_name("only");
  *m->mutable_geometry() = digest('a');
  const BakeRequest r = translate(spec);
  const lightmap::LightmapBakeInput& in = r.lightmap();
  ASSERT_EQ(in.scene.instances.size(), 1u);  // every mesh once
  ASSERT_EQ(in.scene.materials.size(), 1u);  // Lambert 0.8
  EXPECT_EQ(in.scene.materials[0].bsdf.diffuse.albedo.r, 0.8);
  EXPECT_EQ(in.scene.materials[0].bsdf.specular_weight, 0.0);
  EXPECT_FALSE(in.scene.environment.present());
  EXPECT_EQ(in.resolution, 256);
  EXPECT_EQ(in.padding, 4);
  EXPECT_EQ(in.max_bounces, 64);
  EXPECT_EQ(in.max_samples, 4096u);
  EXPECT_EQ(in.target_error, 0.01);
  EXPECT_EQ(in.error_metric, lightmap::ErrorMetric::lightmap);
  EXPECT_EQ(in.generate_uvs, uvgen::GenerateUvs::automatic);  // the default: only where a mesh has none usable
  EXPECT_TRUE(in.preview);
  EXPECT_TRUE(in.stitch_seams);
}

TEST(TranslateLightmap, ConstantEnvironmentTakesItsIntensity) {
  v1::JobSpec spec = full_job();
  v1::SceneEnvironment* env = spec.mutable_lightmap()->mutable_environment();
  env->Clear();
  set(env->mutable_constant(), 1, 2, 3);
  env->set_intensity(0.5);
  const BakeRequest r = translate(spec);
  ASSERT_TRUE(r.lightmap().scene.environment.constant);
  EXPECT_EQ(r.lightmap().scene.environment.constant->g, 1.0);
  EXPECT_EQ(r.inputs.size(), 3u);
}

struct BadCase {
  const char* field;
  std::function<void(v1::JobSpec&)> spoil;
};

// Each case spoils a good job; translation must refuse it, naming the case's field and saying why.
void expect_each_refused(const std::vector<BadCase>& cases, const v1::JobSpec& good) {
  for (const BadCase& c : cases) {
    v1::JobSpec spec = good;
    c.spoil(spec);
    try {
      translate(spec);
      ADD_FAILURE() << "accepted a job with a bad " << c.field;
    } catch (const InvalidField& e) {
      EXPECT_EQ(e.field(), c.field) << e.what();
      EXPECT_GT(std::string(e.what()).size(), e.field().size() + 10) << "no explanation: " << e.what();
    }
  }
}

TEST(TranslateLightmap, BadFieldsAreNamedByTheirPath) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto lm = [](v1::JobSpec& s) { return s.mutable_lightmap(); };
  const std::vector<BadCase> cases = {
      {"job.lightmap.meshes", [&](v1::JobSpec& s) { lm(s)->clear_meshes(); }},
      {"job.lightmap.meshes[1].name", [&](v1::JobSpec& s) { lm(s)->mutable_meshes(1)->set_name("floor"); }},
      {"job.lightmap.meshes[0].name",
       [&](v1::JobSpec& s) { lm(s)->mutable_meshes(0)->set_name(std::string(257, 'x')); }},
      {"job.lightmap.meshes[0].name", [&](v1::JobSpec& s) { lm(s)->mutable_meshes(0)->clear_name(); }},
      {"job.lightmap.meshes[1].geometry", [&](v1::JobSpec& s) { lm(s)->mutable_meshes(1)->clear_geometry(); }},
      {"job.lightmap.meshes[1].geometry.sha256",
       [&](v1::JobSpec& s) { lm(s)->mutable_meshes(1)->mutable_geometry()->set_sha256("xyz"); }},
      {"job.lightmap.meshes[0].geometry.size",
       [&](v1::JobSpec& s) { lm(s)->mutable_meshes(0)->mutable_geometry()->set_size(uint64_t{1} << 40); }},
      {"job.lightmap.instances[1].mesh", [&](v1::JobSpec& s) { lm(s)->mutable_instances(1)->set_mesh(2); }},
      {"job.lightmap.instances[1].transform", [&](v1::JobSpec& s) { lm(s)->mutable_instances(1)->add_transform(1); }},
      {"job.lightmap.instances[1].transform[4]",
       [&](v1::JobSpec& s) { lm(s)->mutable_instances(1)->set_transform(4, nan); }},
      {"job.lightmap.instances[1].lightmap_scale_offset[0]",
       [&](v1::JobSpec& s) { lm(s)->mutable_instances(1)->set_lightmap_scale_offset(0, 0); }},
      {"job.lightmap.instances[1].lightmap_scale_offset",
       [&](v1::JobSpec& s) { lm(s)->mutable_instances(1)->add_lightmap_scale_offset(0); }},
      {"job.lightmap.textures[0].color_space",
       [&](v1::JobSpec& s) { lm(s)->mutable_textures(0)->set_color_space("no such space"); }},
      {"job.lightmap.materials[1].name", [&](v1::JobSpec& s) { lm(s)->mutable_materials(1)->set_name("white"); }},
      {"job.lightmap.materials[0].base_color.g",
       [&](v1::JobSpec& s) { lm(s)->mutable_materials(0)->mutable_base_color()->set_g(1.5); }},
      {"job.lightmap.materials[0].base_color_texture",
       [&](v1::JobSpec& s) { lm(s)->mutable_materials(0)->set_base_color_texture(1); }},
      {"job.lightmap.materials[1].emission.r",
       [&](v1::JobSpec& s) { lm(s)->mutable_materials(1)->mutable_emission()->set_r(-1); }},
      {"job.lightmap.materials[1].bsdf.specular.ggx.alpha",
       [&](v1::JobSpec& s) {
         lm(s)->mutable_materials(1)->mutable_bsdf()->mutable_specular()->mutable_ggx()->set_alpha(2);
       }},
      {"job.lightmap.material_overrides[0].name",
       [&](v1::JobSpec& s) { lm(s)->mutable_material_overrides(0)->set_name("marble"); }},
      {"job.lightmap.material_overrides[1].name",
       [&](v1::JobSpec& s) { *lm(s)->add_material_overrides() = lm(s)->material_overrides(0); }},
      {"job.lightmap.material_overrides[0].bsdf.diffuse.oren_nayar.sigma",
       [&](v1::JobSpec& s) {
         lm(s)->mutable_material_overrides(0)->mutable_bsdf()->mutable_diffuse()->mutable_oren_nayar()->set_sigma(3);
       }},
      {"job.lightmap.lights[0].color.b",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(0)->mutable_color()->set_b(1e13); }},
      {"job.lightmap.lights[0].point.position.y",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(0)->mutable_point()->mutable_position()->set_y(nan); }},
      {"job.lightmap.lights[1].spot.outer_cone_angle",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(1)->mutable_spot()->set_outer_cone_angle(2); }},
      {"job.lightmap.lights[1].spot.inner_cone_angle",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(1)->mutable_spot()->set_inner_cone_angle(0.6); }},
      {"job.lightmap.lights[1].spot.direction",
       [&](v1::JobSpec& s) { set(lm(s)->mutable_lights(1)->mutable_spot()->mutable_direction(), 0, 0, 0); }},
      {"job.lightmap.lights[2].directional.direction",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(2)->mutable_directional()->clear_direction(); }},
      {"job.lightmap.lights[2].directional.angular_diameter",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(2)->mutable_directional()->set_angular_diameter(0.6); }},
      {"job.lightmap.lights[3].rect.v",
       [&](v1::JobSpec& s) { set(lm(s)->mutable_lights(3)->mutable_rect()->mutable_v(), 3, 0, 0); }},
      {"job.lightmap.lights[4].disk.radius",
       [&](v1::JobSpec& s) { lm(s)->mutable_lights(4)->mutable_disk()->set_radius(0); }},
      {"job.lightmap.lights[4]", [&](v1::JobSpec& s) { lm(s)->mutable_lights(4)->clear_disk(); }},
      {"job.lightmap.lights[1].name", [&](v1::JobSpec& s) { lm(s)->mutable_lights(1)->set_name("bulb"); }},
      {"job.lightmap.environment", [&](v1::JobSpec& s) { lm(s)->mutable_environment()->clear_image(); }},
      {"job.lightmap.environment.color_space",
       [&](v1::JobSpec& s) { lm(s)->mutable_environment()->set_color_space("nope"); }},
      {"job.lightmap.environment.rotation_degrees",
       [&](v1::JobSpec& s) { lm(s)->mutable_environment()->set_rotation_degrees(400); }},
      {"job.lightmap.environment.intensity", [&](v1::JobSpec& s) { lm(s)->mutable_environment()->set_intensity(0); }},
      {"job.lightmap.environment.constant.r",
       [&](v1::JobSpec& s) { set(lm(s)->mutable_environment()->mutable_constant(), 2e6, 0, 0); }},
      {"job.lightmap.resolution", [&](v1::JobSpec& s) { lm(s)->set_resolution(3); }},
      {"job.lightmap.resolution",
       [&](v1::JobSpec& s) {  // at least 5 lightmaps of 8192²: more than 2^28 texels
         lm(s)->set_resolution(8192);
         for (int i = 0; i < 5; ++i) {
           v1::Instance* inst = lm(s)->add_instances();
           inst->set_mesh(0);
           inst->set_lightmap("page" + std::to_string(i));
         }
       }},
      {"job.lightmap.memory_limit_bytes", [&](v1::JobSpec& s) { lm(s)->set_memory_limit_bytes(1000); }},
      {"job.lightmap.lightmaps[0].resolution",
       [&](v1::JobSpec& s) { lm(s)->mutable_lightmaps(0)->set_resolution(9000); }},
      {"job.lightmap.lightmaps[0].name", [&](v1::JobSpec& s) { lm(s)->mutable_lightmaps(0)->set_name("nowhere"); }},
      {"job.lightmap.padding", [&](v1::JobSpec& s) { lm(s)->set_padding(65); }},
      {"job.lightmap.max_bounces", [&](v1::JobSpec& s) { lm(s)->set_max_bounces(2000); }},
      {"job.quality.samples", [&](v1::JobSpec& s) { s.mutable_quality()->set_samples(0); }},
      {"job.quality.samples", [&](v1::JobSpec& s) { s.mutable_quality()->set_samples((1 << 20) + 1); }},
      {"job.quality.target_error", [&](v1::JobSpec& s) { s.mutable_quality()->set_target_error(0); }},
      {"job.quality.time_limit_seconds", [&](v1::JobSpec& s) { s.mutable_quality()->set_time_limit_seconds(-1); }},
      {"job.force_effects[warp_drive]", [&](v1::JobSpec& s) { (*s.mutable_force_effects())["warp_drive"] = true; }},
      {"job.lightmap.error_metric",
       [&](v1::JobSpec& s) { lm(s)->set_error_metric(static_cast<v1::LightmapErrorMetric>(7)); }},
      {"job.lightmap.generate_uvs",
       [&](v1::JobSpec& s) { lm(s)->set_generate_uvs(static_cast<v1::GenerateUvs>(9)); }},
      {"job.lightmap",
       [&](v1::JobSpec& s) {  // 10 blobs of 500 MiB: beyond the 4 GiB a job may read
         for (int i = 0; i < 10; ++i) {
           v1::Mesh* m = lm(s)->add_meshes();
           m->set_name("big" + std::to_string(i));
           *m->mutable_geometry() = digest('e', uint64_t{500} << 20);
         }
       }},
  };
  ASSERT_GE(cases.size(), 25u);
  expect_each_refused(cases, full_job());
}

// The layout of kiln.proto written out here by hand, field by field.
struct BlobWriter {
  std::string bytes = "KILNMSH1";
  void u32(uint32_t v) { bytes.append(reinterpret_cast<const char*>(&v), 4); }
  void f32(float v) { bytes.append(reinterpret_cast<const char*>(&v), 4); }
};

// One triangle with normals and lightmap UVs, material index 2.
std::string triangle_blob(uint32_t flags = 1u | 4u | 8u) {
  BlobWriter w;
  w.u32(3);
  w.u32(1);
  w.u32(flags);
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 0.f, 1.f}) w.f32(v);
  if (flags & 1u)
    for (int i = 0; i < 3; ++i)
      for (float v : {0.f, 1.f, 0.f}) w.f32(v);
  if (flags & 2u)
    for (float v : {0.f, 0.f, 1.f, 0.f, 0.f, 1.f}) w.f32(v);
  if (flags & 4u)
    for (float v : {0.1f, 0.1f, 0.9f, 0.1f, 0.1f, 0.9f}) w.f32(v);
  for (uint32_t i : {0u, 2u, 1u}) w.u32(i);
  if (flags & 8u) w.u32(2);
  return w.bytes;
}

TEST(MeshBlob, DecodesTheDocumentedLayout) {
  const scene::Mesh m = decode_mesh_blob(triangle_blob(), "f", "tri");
  EXPECT_EQ(m.name, "tri");
  ASSERT_EQ(m.positions.size(), 3u);
  EXPECT_EQ(m.positions[1].x, 1.0);
  EXPECT_EQ(m.positions[2].z, 1.0);
  ASSERT_EQ(m.normals.size(), 3u);
  EXPECT_EQ(m.normals[0].y, 1.0);
  EXPECT_TRUE(m.uv.empty());
  ASSERT_EQ(m.lightmap_uv.size(), 3u);
  EXPECT_FLOAT_EQ(static_cast<float>(m.lightmap_uv[1].x), 0.9f);  // stored as float32
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 2, 1}));
  EXPECT_EQ(m.material, (std::vector<uint32_t>{2}));
  // Every flag combination decodes to the arrays it announces.
  for (uint32_t flags = 0; flags < 16; ++flags) {
    const scene::Mesh k = decode_mesh_blob(triangle_blob(flags), "f", "tri");
    EXPECT_EQ(k.normals.size(), (flags & 1u) ? 3u : 0u);
    EXPECT_EQ(k.uv.size(), (flags & 2u) ? 3u : 0u);
    EXPECT_EQ(k.lightmap_uv.size(), (flags & 4u) ? 3u : 0u);
    EXPECT_EQ(k.material.size(), (flags & 8u) ? 1u : 0u);
  }
}

// A blob of 0 vertices and 0 triangles (any flags) is in the layout: it decodes to empty arrays, and the bake's
// scene check says what is wrong with an empty mesh. Decoding it once copied 0 bytes to a null pointer, undefined
// behaviour that the sanitizer build reports (found by tests/fuzz/mesh_blob_fuzz.cpp).
TEST(MeshBlob, AnEmptyMeshDecodesToEmptyArrays) {
  for (uint32_t flags : {0u, 15u}) {
    BlobWriter w;
    w.u32(0);
    w.u32(0);
    w.u32(flags);
    const scene::Mesh m = decode_mesh_blob(w.bytes, "f", "empty");
    EXPECT_TRUE(m.positions.empty() && m.normals.empty() && m.uv.empty() && m.lightmap_uv.empty());
    EXPECT_TRUE(m.indices.empty() && m.material.empty());
  }
}

TEST(MeshBlob, MalformedBlobsAreRefusedNamingTheField) {
  const std::string good = triangle_blob();
  const std::string field = "job.lightmap.meshes[3].geometry";
  auto refused = [&](const std::string& bytes, const char* what) {
    try {
      decode_mesh_blob(bytes, field, "m");
      ADD_FAILURE() << "decoded a blob with " << what;
    } catch (const InvalidField& e) {
      EXPECT_EQ(e.field(), field) << what;
    }
  };
  refused(good.substr(0, good.size() - 1), "a truncated end");
  refused(good.substr(0, 10), "a truncated header");
  refused("", "no bytes");
  refused(good + "x", "a trailing byte");
  std::string magic = good;
  magic[7] = '2';
  refused(magic, "a wrong magic");
  std::string flags = good;
  const uint32_t bad_flags = 16 | 1;
  std::memcpy(flags.data() + 16, &bad_flags, 4);
  refused(flags, "an unknown flag bit");
  std::string huge = good;
  const uint32_t too_many = kMaxMeshBlobCount + 1;
  std::memcpy(huge.data() + 8, &too_many, 4);
  refused(huge, "a vertex count beyond the bound");
  std::memcpy(huge.data() + 8, good.data() + 8, 4);
  std::memcpy(huge.data() + 12, &too_many, 4);
  refused(huge, "a triangle count beyond the bound");
  std::string mismatch = good;
  const uint32_t four = 4;
  std::memcpy(mismatch.data() + 8, &four, 4);  // one more vertex than the arrays hold
  refused(mismatch, "a size that does not match the header");
}

TEST(TranslateLightmap, CacheKeyFollowsSettingsAndBlobsOnly) {
  const v1::JobSpec base = full_job();
  const std::string key = cache_key(translate(base), baker_version(translate(base)));
  // Stable: the same job, and the same job under another name, has the same key.
  v1::JobSpec renamed = base;
  renamed.set_name("another name");
  EXPECT_EQ(cache_key(translate(renamed), lightmap::kLightmapBakerVersion), key);
  // A default written out equals the default left out.
  v1::JobSpec plain;
  v1::Mesh* m = plain.mutable_lightmap()->add_meshes();
  m->set_name("only");
  *m->mutable_geometry() = digest('a');
  v1::JobSpec explicit_defaults = plain;
  explicit_defaults.mutable_lightmap()->set_resolution(256);
  explicit_defaults.mutable_lightmap()->set_padding(4);
  explicit_defaults.mutable_lightmap()->set_preview(true);
  explicit_defaults.mutable_lightmap()->set_stitch_seams(true);
  explicit_defaults.mutable_lightmap()->set_error_metric(v1::LIGHTMAP_ERROR_METRIC_LIGHTMAP);
  explicit_defaults.mutable_lightmap()->set_generate_uvs(v1::GENERATE_UVS_AUTO);
  explicit_defaults.mutable_quality()->set_samples(4096);
  EXPECT_EQ(cache_key(translate(plain), "v"), cache_key(translate(explicit_defaults), "v"));
  // Different: any setting, any blob, any scene field, the baker version.
  const std::vector<std::function<void(v1::JobSpec&)>> changes = {
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_resolution(33); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_padding(3); },
      [](v1::JobSpec& s) { s.mutable_quality()->set_seed(8); },
      [](v1::JobSpec& s) { s.mutable_quality()->set_target_error(0.04); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_ao(false); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_denoise(false); },  // a raw job shares no entry with it
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_stitch_seams(true); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_error_metric(v1::LIGHTMAP_ERROR_METRIC_LIGHTMAP); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_generate_uvs(v1::GENERATE_UVS_NEVER); },
      [](v1::JobSpec& s) { *s.mutable_lightmap()->mutable_meshes(1)->mutable_geometry() = digest('f'); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_lights(0)->mutable_color()->set_r(11); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_materials(1)->mutable_emission()->set_g(13); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_environment()->set_intensity(3); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_instances(1)->set_transform(3, 1.5); },
      [](v1::JobSpec& s) { s.mutable_force_effects()->clear(); },
  };
  for (std::size_t i = 0; i < changes.size(); ++i) {
    v1::JobSpec changed = base;
    changes[i](changed);
    EXPECT_NE(cache_key(translate(changed), lightmap::kLightmapBakerVersion), key) << "change " << i;
  }
  EXPECT_NE(cache_key(translate(base), "kiln-lightmap-0"), key);
}

// A job that packs atlas pages: two instances of one mesh, one with its own density, one on a page of its own.
v1::JobSpec atlas_job() {
  v1::JobSpec spec;
  v1::LightmapJob* j = spec.mutable_lightmap();
  v1::Mesh* m = j->add_meshes();
  m->set_name("tile");
  *m->mutable_geometry() = digest('a');
  v1::Instance* a = j->add_instances();
  a->set_name("left tile");
  a->set_texel_density(40);
  v1::Instance* b = j->add_instances();
  b->set_lightmap("ignored when packing");
  b->set_own_page(true);
  j->set_texel_density(20);
  j->set_page_size(512);
  j->set_max_pages(8);
  return spec;
}

TEST(TranslateLightmap, AtlasFieldsMapOntoTheBakersInput) {
  const BakeRequest r = translate(atlas_job());
  const lightmap::LightmapBakeInput& in = r.lightmap();
  EXPECT_EQ(in.atlas.texel_density, 20);
  EXPECT_EQ(in.atlas.page_size, 512);
  EXPECT_EQ(in.atlas.max_pages, 8);
  EXPECT_FALSE(in.atlas.uniform_pages);
  v1::JobSpec uniform = atlas_job();
  uniform.mutable_lightmap()->set_uniform_pages(true);
  EXPECT_TRUE(translate(uniform).lightmap().atlas.uniform_pages);
  ASSERT_EQ(in.atlas.instances.size(), 2u);
  EXPECT_EQ(in.atlas.instances.at(0).texel_density, 40);
  EXPECT_FALSE(in.atlas.instances.at(0).own_page);
  EXPECT_TRUE(in.atlas.instances.at(1).own_page);
  EXPECT_EQ(in.scene.instances[0].name, "left tile");
  // The memory estimate counts max_pages whole pages.
  v1::JobSpec fewer = atlas_job();
  fewer.mutable_lightmap()->set_max_pages(1);
  EXPECT_GT(r.memory_bytes, translate(fewer).memory_bytes + 6 * 512 * 512 * 100);
  EXPECT_EQ(r.memory_field, "job.lightmap.max_pages");
  // Defaults: 1024 texels a page, 4 pages; still 4 at the largest page, 8192² (4 × 2^26 = the job's 2^28 texels).
  v1::JobSpec defaults = atlas_job();
  defaults.mutable_lightmap()->clear_page_size();
  defaults.mutable_lightmap()->clear_max_pages();
  EXPECT_EQ(translate(defaults).lightmap().atlas.page_size, 1024);
  EXPECT_EQ(translate(defaults).lightmap().atlas.max_pages, 4);
  defaults.mutable_lightmap()->set_page_size(8192);
  EXPECT_EQ(translate(defaults).lightmap().atlas.max_pages, 4);
  // Without a density nothing packs.
  v1::JobSpec none = atlas_job();
  none.mutable_lightmap()->clear_texel_density();
  none.mutable_lightmap()->clear_page_size();
  none.mutable_lightmap()->clear_max_pages();
  none.mutable_lightmap()->mutable_instances(0)->clear_texel_density();
  none.mutable_lightmap()->mutable_instances(1)->clear_own_page();
  EXPECT_EQ(translate(none).lightmap().atlas.texel_density, 0);
}

TEST(TranslateLightmap, BadAtlasFieldsAreNamedByTheirPath) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto lm = [](v1::JobSpec& s) { return s.mutable_lightmap(); };
  const std::vector<BadCase> cases = {
      {"job.lightmap.texel_density", [&](v1::JobSpec& s) { lm(s)->set_texel_density(0); }},
      {"job.lightmap.texel_density", [&](v1::JobSpec& s) { lm(s)->set_texel_density(nan); }},
      {"job.lightmap.texel_density", [&](v1::JobSpec& s) { lm(s)->set_texel_density(2e6); }},
      {"job.lightmap.page_size", [&](v1::JobSpec& s) { lm(s)->set_page_size(15); }},
      {"job.lightmap.page_size", [&](v1::JobSpec& s) { lm(s)->set_page_size(8193); }},
      {"job.lightmap.max_pages", [&](v1::JobSpec& s) { lm(s)->set_max_pages(0); }},
      {"job.lightmap.max_pages", [&](v1::JobSpec& s) { lm(s)->set_max_pages(1025); }},  // 1025 × 512² > 2^28
      {"job.lightmap.instances[0].texel_density",
       [&](v1::JobSpec& s) { lm(s)->mutable_instances(0)->set_texel_density(-1); }},
      {"job.lightmap.instances[1].lightmap_scale_offset",
       [&](v1::JobSpec& s) {
         for (double v : {0.5, 0.5, 0.0, 0.0}) lm(s)->mutable_instances(1)->add_lightmap_scale_offset(v);
       }},
      {"job.lightmap.lightmaps[0]",
       [&](v1::JobSpec& s) {
         v1::LightmapSettings* l = lm(s)->add_lightmaps();
         l->set_name("tile");
         l->set_resolution(64);
       }},
      {"job.lightmap.instances[0].name",
       [&](v1::JobSpec& s) { lm(s)->mutable_instances(0)->set_name(std::string(257, 'n')); }},
      // Packing options without packing.
      {"job.lightmap.page_size", [&](v1::JobSpec& s) { lm(s)->clear_texel_density(); }},
      {"job.lightmap.max_pages",
       [&](v1::JobSpec& s) {
         lm(s)->clear_texel_density();
         lm(s)->clear_page_size();
       }},
      {"job.lightmap.uniform_pages",
       [&](v1::JobSpec& s) {
         lm(s)->clear_texel_density();
         lm(s)->clear_page_size();
         lm(s)->clear_max_pages();
         lm(s)->set_uniform_pages(true);
       }},
      {"job.lightmap.instances[0].texel_density",
       [&](v1::JobSpec& s) {
         lm(s)->clear_texel_density();
         lm(s)->clear_page_size();
         lm(s)->clear_max_pages();
       }},
      {"job.lightmap.instances[1].own_page",
       [&](v1::JobSpec& s) {
         lm(s)->clear_texel_density();
         lm(s)->clear_page_size();
         lm(s)->clear_max_pages();
         lm(s)->mutable_instances(0)->clear_texel_density();
       }},
  };
  expect_each_refused(cases, atlas_job());
}

TEST(TranslateLightmap, AtlasSettingsAreInTheCacheKey) {
  const v1::JobSpec base = atlas_job();
  const std::string key = cache_key(translate(base), "v");
  const std::vector<std::function<void(v1::JobSpec&)>> changes = {
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_texel_density(21); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_page_size(256); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_max_pages(7); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->set_uniform_pages(true); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_instances(0)->set_texel_density(41); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_instances(1)->set_own_page(false); },
      [](v1::JobSpec& s) { s.mutable_lightmap()->mutable_instances(0)->set_name("right tile"); },
  };
  for (std::size_t i = 0; i < changes.size(); ++i) {
    v1::JobSpec changed = base;
    changes[i](changed);
    EXPECT_NE(cache_key(translate(changed), "v"), key) << "change " << i;
  }
  // Defaults written out equal defaults left out.
  v1::JobSpec a = base, b = base;
  a.mutable_lightmap()->clear_page_size();
  a.mutable_lightmap()->clear_max_pages();
  b.mutable_lightmap()->set_page_size(1024);
  b.mutable_lightmap()->set_max_pages(4);
  EXPECT_EQ(cache_key(translate(a), "v"), cache_key(translate(b), "v"));
}

}  // namespace
}  // namespace kiln::daemon

namespace kiln::daemon {
namespace {

// A memory limit below a job's whole estimate, the job's own or kilnd's, bakes it in tiles whose estimate fits the
// limit; the tile size is part of the cache key, and without a limit nothing changes.
TEST(TranslateLightmap, AMemoryLimitBelowTheEstimateBakesInTiles) {
  v1::JobSpec spec = full_job();
  spec.mutable_lightmap()->set_resolution(1024);  // texels dominate the estimate
  BakeRequest whole = translate(spec);
  const std::string whole_key = cache_key(whole, baker_version(whole));
  fit_memory_limit(whole, 0);
  EXPECT_EQ(whole.lightmap().tile_size, 0);
  EXPECT_EQ(cache_key(whole, baker_version(whole)), whole_key);
  const uint64_t limit = whole.memory_bytes / 3;

  BakeRequest by_kilnd = translate(spec);
  fit_memory_limit(by_kilnd, limit);
  EXPECT_GE(by_kilnd.lightmap().tile_size, lightmap::kMinTileSize);
  EXPECT_LE(by_kilnd.memory_bytes, limit);
  EXPECT_EQ(by_kilnd.lightmap().memory_limit_bytes, limit);
  EXPECT_NE(cache_key(by_kilnd, baker_version(by_kilnd)), whole_key);
  EXPECT_NE(by_kilnd.memory_note.find("in tiles of"), std::string::npos) << by_kilnd.memory_note;

  spec.mutable_lightmap()->set_memory_limit_bytes(limit);
  BakeRequest by_job = translate(spec);
  EXPECT_EQ(by_job.lightmap().tile_size, by_kilnd.lightmap().tile_size) << "the job's own limit plans the same";
  fit_memory_limit(by_job, whole.memory_bytes * 2);  // kilnd's roomier limit does not lift the job's
  EXPECT_EQ(by_job.lightmap().tile_size, by_kilnd.lightmap().tile_size);
}

}  // namespace
}  // namespace kiln::daemon
