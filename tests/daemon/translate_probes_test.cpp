// The probes job's translation (daemon/translate_probes.cpp): the scene as a lightmap job's, its fields named under
// job.probes.scene; the volume's settings onto the baker's probe options with their defaults, each bad one refused
// naming its path; a lightmap job's probes under job.lightmap.probes; the memory estimate counting max_probes (and
// naming it when the probes drive it) and no lightmap; cache keys that tell a probes job from a lightmap job.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "daemon/translate.h"
#include "proto/bounds.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {
namespace {

v1::LightmapJob scene() {
  v1::LightmapJob j;
  v1::Mesh* m = j.add_meshes();
  m->set_name("floor");
  m->mutable_geometry()->set_sha256(std::string(64, 'a'));
  m->mutable_geometry()->set_size(1000);
  j.mutable_environment()->mutable_constant()->set_r(1);
  return j;
}

v1::JobSpec probes_job() {
  v1::JobSpec spec;
  *spec.mutable_probes()->mutable_scene() = scene();
  spec.mutable_probes()->mutable_volume()->set_spacing(0.5);
  return spec;
}

std::string refused(const v1::JobSpec& spec) {
  try {
    translate(spec);
  } catch (const InvalidField& e) {
    return e.field();
  }
  return "(accepted)";
}

TEST(TranslateProbes, AProbesJobIsALightmapInputThatBakesNoLightmap) {
  v1::JobSpec spec = probes_job();
  v1::MediumBox* box = spec.mutable_probes()->mutable_volume()->add_regions();
  box->mutable_lo()->set_x(-1);
  box->mutable_hi()->set_x(1), box->mutable_hi()->set_y(2), box->mutable_hi()->set_z(3);
  spec.mutable_probes()->mutable_volume()->set_max_probes(1000);
  const BakeRequest r = translate(spec);
  EXPECT_STREQ(job_type(r), "probes");
  const lightmap::LightmapBakeInput& in = r.lightmap();
  EXPECT_FALSE(in.lightmaps);
  EXPECT_EQ(in.probes.spacing, 0.5);
  EXPECT_EQ(in.probes.distance(), 1.0);  // default 2 x spacing
  EXPECT_EQ(in.probes.max_probes, 1000u);
  ASSERT_EQ(in.probes.regions.size(), 1u);
  EXPECT_EQ(in.probes.regions[0].hi.z, 3.0);
  EXPECT_EQ(in.generate_uvs, uvgen::GenerateUvs::never);  // probes need no lightmap UVs
  ASSERT_EQ(r.inputs.size(), 1u);
  EXPECT_EQ(r.inputs[0].field, "job.probes.scene.meshes[0].geometry");
  EXPECT_NE(r.memory_note.find("1000 light probes"), std::string::npos) << r.memory_note;
}

TEST(TranslateProbes, BadSettingsAreRefusedNamingTheirPath) {
  auto with = [](auto change) {
    v1::JobSpec spec = probes_job();
    change(*spec.mutable_probes()->mutable_volume());
    return refused(spec);
  };
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.set_spacing(0); }), "job.probes.volume.spacing");
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.set_spacing(-1); }), "job.probes.volume.spacing");
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.set_spacing(std::nan("")); }), "job.probes.volume.spacing");
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.set_max_distance(std::nan("")); }), "job.probes.volume.max_distance");
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.set_max_probes(0); }), "job.probes.volume.max_probes");
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.set_max_probes((1u << 22) + 1); }), "job.probes.volume.max_probes");
  EXPECT_EQ(with([](v1::ProbeVolume& v) { v.add_regions()->mutable_hi()->set_x(1); }),
            "job.probes.volume.regions[0].lo");
  EXPECT_EQ(with([](v1::ProbeVolume& v) {
              v1::MediumBox* b = v.add_regions();
              b->mutable_lo();
              b->mutable_hi()->set_x(1), b->mutable_hi()->set_z(1);  // flat in y
            }),
            "job.probes.volume.regions[0].hi");
  EXPECT_EQ(with([](v1::ProbeVolume& v) {
              v1::MediumBox* b = v.add_regions();
              b->mutable_lo()->set_y(std::nan(""));
              b->mutable_hi()->set_x(1);
            }),
            "job.probes.volume.regions[0].lo.y");
  EXPECT_EQ(with([](v1::ProbeVolume& v) {
              for (int i = 0; i < 17; ++i) v.add_regions();
            }),
            "job.probes.volume.regions");
  v1::JobSpec no_volume = probes_job();
  no_volume.mutable_probes()->clear_volume();
  EXPECT_EQ(refused(no_volume), "job.probes.volume");
  v1::JobSpec no_scene = probes_job();
  no_scene.mutable_probes()->clear_scene();
  EXPECT_EQ(refused(no_scene), "job.probes.scene");
  v1::JobSpec bad_scene = probes_job();
  bad_scene.mutable_probes()->mutable_scene()->set_max_bounces(5000);
  EXPECT_EQ(refused(bad_scene), "job.probes.scene.max_bounces");
  v1::JobSpec nested = probes_job();
  nested.mutable_probes()->mutable_scene()->mutable_probes()->set_spacing(1);
  EXPECT_EQ(refused(nested), "job.probes.scene.probes");
}

TEST(TranslateProbes, MemoryCountsTheProbesAndNamesMaxProbesWhenTheyDriveIt) {
  v1::JobSpec few = probes_job(), many = probes_job();
  few.mutable_probes()->mutable_volume()->set_max_probes(1);
  many.mutable_probes()->mutable_volume()->set_max_probes(1u << 22);
  const BakeRequest a = translate(few), b = translate(many);
  // 4 KiB a probe (memory_estimate.h's kProbeBytes): the difference is exactly the probes' (both place probes).
  EXPECT_EQ(b.memory_bytes - a.memory_bytes, ((uint64_t{1} << 22) - 1) * lightmap::kProbeBytes);
  EXPECT_EQ(b.memory_field, "job.probes.volume.max_probes");
  // The lightmap job of the same scene, with and without probes: its estimate counts them too.
  v1::JobSpec lightmap;
  *lightmap.mutable_lightmap() = scene();
  const BakeRequest plain = translate(lightmap);
  lightmap.mutable_lightmap()->mutable_probes()->set_spacing(0.5);
  lightmap.mutable_lightmap()->mutable_probes()->set_max_probes(1u << 22);
  const BakeRequest with = translate(lightmap);
  // Plus the placement's copy of the traced triangles: a 1000-byte mesh blob holds at most (1000 - 20) / 12 = 81.
  EXPECT_EQ(with.memory_bytes - plain.memory_bytes,
            (uint64_t{1} << 22) * lightmap::kProbeBytes + 81 * lightmap::kProbePlacementBytesPerTriangle);
  EXPECT_EQ(with.memory_field, "job.lightmap.probes.max_probes");
}

TEST(TranslateProbes, CacheKeysTellProbesFromLightmapsAndFollowTheSettings) {
  v1::JobSpec lightmap;
  *lightmap.mutable_lightmap() = scene();
  v1::JobSpec with_probes = lightmap;
  with_probes.mutable_lightmap()->mutable_probes()->set_spacing(0.5);
  v1::JobSpec finer = probes_job();
  finer.mutable_probes()->mutable_volume()->set_spacing(0.25);
  const std::string keys[] = {cache_key(translate(lightmap), "v"), cache_key(translate(with_probes), "v"),
                              cache_key(translate(probes_job()), "v"), cache_key(translate(finer), "v")};
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) EXPECT_NE(keys[i], keys[j]) << i << " " << j;
  EXPECT_EQ(cache_key(translate(probes_job()), "v"), keys[2]);
  // A lightmap job's key without probes is what it was: no probes line in its canonical text.
  EXPECT_EQ(canonical_text(translate(lightmap)).find("probes"), std::string::npos);
}

TEST(TranslateProbes, ALightmapJobsProbesAreNamedUnderIt) {
  v1::JobSpec spec;
  *spec.mutable_lightmap() = scene();
  spec.mutable_lightmap()->mutable_probes()->set_max_distance(1);
  EXPECT_EQ(refused(spec), "job.lightmap.probes.spacing");
  spec.mutable_lightmap()->mutable_probes()->set_spacing(2);
  const BakeRequest r = translate(spec);
  EXPECT_TRUE(r.lightmap().lightmaps);
  EXPECT_STREQ(job_type(r), "lightmap");
  EXPECT_EQ(r.lightmap().probes.distance(), 1.0);
}

}  // namespace
}  // namespace kiln::daemon
