// LightmapJob.media through the translation layer: each kind of medium maps onto the baker's input with the
// documented defaults, every bound is refused naming its field, and a VDB blob is read from the store by the
// worker's input loading (its grids checked by read_vdb, a bad file refused naming the blob's field).
#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <tuple>
#include <vector>

#include "bakers/volume/vdb_file.h"
#include "daemon/store/blob_store.h"
#include "daemon/translate.h"
#include "proto/kiln.pb.h"
#include "tests/support/temp_dir.h"

namespace kiln::daemon {
namespace {

const std::string kMeshDigest =
    "sha256: \"0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef\" size: 1000";

// A one-mesh lightmap job with `media` (text format) as its media.
v1::JobSpec job_with(const std::string& media) {
  v1::JobSpec spec;
  const std::string text = "lightmap { meshes { name: \"floor\" geometry { " + kMeshDigest + " } } " + media + " }";
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &spec)) << text;
  return spec;
}

TEST(TranslateMedia, EachKindMapsOntoTheBakersInput) {
  const BakeRequest r = translate(
      job_with("media { name: \"haze\" fog: true sigma_a { r: 0.1 g: 0.2 b: 0.3 } sigma_s { r: 1 g: 2 b: 3 } g: 0.5 } "
               "media { box { lo { x: -1 y: 0 z: -2 } hi { x: 1 y: 3 z: 2 } } emission { r: 4 g: 5 b: 6 } g: -1 }"));
  const std::vector<volume::MediumInput>& media = r.lightmap().media;
  ASSERT_EQ(media.size(), 2u);
  EXPECT_EQ(media[0].name, "haze");
  const auto& fog = std::get<volume::HomogeneousMediumSpec>(media[0].spec);
  EXPECT_FALSE(fog.box.has_value());  // everywhere
  EXPECT_EQ(fog.sigma_a.g, 0.2);
  EXPECT_EQ(fog.sigma_s.b, 3.0);
  EXPECT_EQ(fog.g, 0.5);
  EXPECT_EQ(fog.Le.max(), 0.0);
  const auto& box = std::get<volume::HomogeneousMediumSpec>(media[1].spec);
  ASSERT_TRUE(box.box.has_value());
  EXPECT_EQ(box.box->lo.z, -2.0);
  EXPECT_EQ(box.box->hi.y, 3.0);
  EXPECT_EQ(box.Le.g, 5.0);
  EXPECT_EQ(box.sigma_a.max(), 0.0);  // unset coefficients are 0
  EXPECT_EQ(box.g, -1.0);             // accepted; the phase function narrows it
}

TEST(TranslateMedia, AVdbMediumNamesItsBlobAndGrids) {
  const BakeRequest r =
      translate(job_with("media { vdb { file { " + kMeshDigest +
                         " } emission_grid: \"heat\" "
                         "transform: [2, 0, 0, 1, 0, 2, 0, 0, 0, 0, 2, 0] } sigma_s { r: 1 g: 1 b: 1 } }"));
  ASSERT_EQ(r.inputs.size(), 2u);
  EXPECT_EQ(r.inputs[1].field, "job.lightmap.media[0].vdb.file");
  const volume::MediumInput& m = r.lightmap().media.at(0);
  EXPECT_EQ(m.density_grid, "density");  // the default
  EXPECT_EQ(m.emission_grid, "heat");
  const auto& grid = std::get<volume::GridMediumSpec>(m.spec);
  EXPECT_EQ(grid.to_world.m[0], 2.0);
  EXPECT_EQ(grid.to_world.m[3], 1.0);
  EXPECT_EQ(grid.Le_scale.r, 1.0);     // an emission grid without a colour holds the radiance itself
  EXPECT_FALSE(grid.density.valid());  // read by the worker
}

// n media of fog.
std::string fogs(int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += "media { fog: true } ";
  return s;
}

TEST(TranslateMedia, BadFieldsAreNamedByTheirPath) {
  const std::string vdb = "vdb { file { " + kMeshDigest + " } ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"job.lightmap.media[0]", "media { sigma_a { r: 1 } }"},
      {"job.lightmap.media[0].fog", "media { fog: false }"},
      {"job.lightmap.media[0].sigma_a.g", "media { fog: true sigma_a { g: -1 } }"},
      {"job.lightmap.media[0].sigma_s.b", "media { fog: true sigma_s { b: 2e6 } }"},
      {"job.lightmap.media[0].sigma_s.r", "media { fog: true sigma_s { r: nan } }"},
      {"job.lightmap.media[0].g", "media { fog: true g: 1.5 }"},
      {"job.lightmap.media[0].emission.r", "media { fog: true emission { r: 1e7 } }"},
      {"job.lightmap.media[0].name", "media { fog: true name: \"" + std::string(257, 'x') + "\" }"},
      {"job.lightmap.media[0].box.hi", "media { box { lo { x: 1 } } }"},
      {"job.lightmap.media[0].box.lo", "media { box { hi { x: 1 } } }"},
      {"job.lightmap.media[0].box.hi", "media { box { lo { x: 1 } hi { x: 0 } } }"},
      {"job.lightmap.media[0].box.lo.y", "media { box { lo { y: inf } hi { x: 1 } } }"},
      {"job.lightmap.media[0].vdb.file", "media { vdb { } }"},
      {"job.lightmap.media[0].vdb.file.sha256", "media { vdb { file { sha256: \"xyz\" size: 10 } } }"},
      {"job.lightmap.media[0].vdb.file",
       "media { vdb { file { sha256: \"" + std::string(64, 'a') + "\" size: 268435457 } } }"},
      {"job.lightmap.media[0].vdb.transform", "media { " + vdb + "transform: [1, 2, 3] } }"},
      {"job.lightmap.media[0].vdb.transform[5]",
       "media { " + vdb + "transform: [1, 0, 0, 0, 0, 2e9, 0, 0, 0, 0, 1, 0] } }"},
      {"job.lightmap.media[0].vdb.transform", "media { " + vdb + "transform: [1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0] } }"},
      {"job.lightmap.media[0].vdb.emission_grid", "media { " + vdb + "emission_grid: \"density\" } }"},
      {"job.lightmap.media[0].vdb.density_grid",
       "media { " + vdb + "density_grid: \"" + std::string(300, 'd') + "\" } }"},
      {"job.lightmap.media", fogs(17)},
  };
  for (const auto& [field, media] : cases) {
    try {
      translate(job_with(media));
      ADD_FAILURE() << "accepted " << media;
    } catch (const InvalidField& e) {
      EXPECT_EQ(e.field(), field) << media << "\n" << e.what();
    }
  }
  // Sixteen are allowed.
  EXPECT_EQ(translate(job_with(fogs(16))).lightmap().media.size(), 16u);
}

TEST(TranslateMedia, BakerComplaintsNameTheMediumsField) {
  const BakeRequest r = translate(job_with("media { fog: true }"));
  EXPECT_EQ(input_error(r, bake::InvalidInput("media[0].vdb.transform", "is singular")).field(),
            "job.lightmap.media[0].vdb.transform");
}

// A VDB file of one 4³ block of density `value`, and another grid when `heat` is set.
std::string vdb_bytes(float value, bool heat = false) {
  std::vector<volume::VdbGrid> grids{volume::make_vdb_grid("density", 4, 4, 4, std::vector<float>(64, value), 0.5)};
  if (heat) grids.push_back(volume::make_vdb_grid("heat", 2, 2, 2, std::vector<float>(8, 3.0f), 0.5));
  const std::vector<uint8_t> bytes = volume::write_vdb(grids);
  return std::string(bytes.begin(), bytes.end());
}

// Translates a job whose one medium reads `bytes` from a store, then loads that blob alone (the job's mesh blob is
// not what this test is about, and is left out of the loading).
BakeRequest loaded(store::BlobStore& blobs, const std::string& bytes, const std::string& vdb_fields) {
  const store::BlobId id = blobs.put(bytes);
  const std::string mesh = "sha256: \"" + blobs.put("a mesh").digest + "\" size: 6";
  v1::JobSpec spec;
  const std::string text = "lightmap { meshes { name: \"floor\" geometry { " + mesh + " } } media { vdb { file { " +
                           "sha256: \"" + id.digest + "\" size: " + std::to_string(id.size) + " } " + vdb_fields +
                           " } sigma_s { r: 1 g: 1 b: 1 } } }";
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &spec)) << text;
  BakeRequest r = translate(spec, &blobs);
  r.inputs.erase(r.inputs.begin());
  load_inputs(r, blobs);
  return r;
}

TEST(TranslateMedia, TheWorkerReadsTheVdbGrids) {
  test::TempDir dir;
  store::BlobStore blobs(dir.path() / "store");
  const BakeRequest r = loaded(blobs, vdb_bytes(0.25f, true), "emission_grid: \"heat\"");
  const auto& spec = std::get<volume::GridMediumSpec>(r.lightmap().media.at(0).spec);
  ASSERT_TRUE(spec.density.valid());
  EXPECT_EQ(spec.density.active_voxel_count(), 64);
  EXPECT_EQ(spec.density.value(1, 2, 3), 0.25f);
  ASSERT_TRUE(spec.emission.has_value());
  EXPECT_EQ(spec.emission->value(1, 1, 1), 3.0f);
  // The medium the bake makes of it.
  EXPECT_NO_THROW(volume::make_medium(r.lightmap().media[0]));

  // A missing grid, and bytes that are no VDB file: the blob's field, with what read_vdb found.
  for (const auto& [bytes, fields, says] :
       {std::tuple{vdb_bytes(1), std::string("density_grid: \"smoke\""), std::string("smoke")},
        std::tuple{std::string("not a vdb file at all"), std::string(), std::string("OpenVDB")}}) {
    try {
      loaded(blobs, bytes, fields);
      ADD_FAILURE() << "accepted " << fields;
    } catch (const InvalidField& e) {
      EXPECT_EQ(e.field(), "job.lightmap.media[0].vdb.file");
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  }
}

// A VDB file of one dense n³ block of density 1: (n / 8)³ leaves.
std::string block_bytes(int n) {
  const std::vector<uint8_t> bytes = volume::write_vdb(
      {volume::make_vdb_grid("density", n, n, n, std::vector<float>(static_cast<size_t>(n) * n * n, 1.0f), 0.05)});
  return std::string(bytes.begin(), bytes.end());
}

// A job whose one medium reads `bytes` from the store, translated and sized as at submit (service.cpp).
BakeRequest sized(store::BlobStore& blobs, const std::string& bytes, const std::string& vdb_fields = "",
                  int resolution = 16) {
  const store::BlobId id = blobs.put(bytes);
  const std::string mesh = "sha256: \"" + blobs.put("a mesh").digest + "\" size: 6";
  v1::JobSpec spec;
  const std::string text = "lightmap { resolution: " + std::to_string(resolution) +
                           " meshes { name: \"floor\" geometry { " + mesh + " } } media { vdb { file { sha256: \"" +
                           id.digest + "\" size: " + std::to_string(id.size) + " } " + vdb_fields +
                           " } sigma_s { r: 1 g: 1 b: 1 } } }";
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &spec)) << text;
  BakeRequest r = translate(spec, &blobs);
  size_vdb_media(r, blobs);
  fit_memory_limit(r, 0);
  return r;
}

TEST(TranslateMedia, TheEstimateCountsTheVdbGridsLeaves) {
  test::TempDir dir;
  store::BlobStore blobs(dir.path() / "store");
  uint64_t previous = 0, rest = 0;
  for (int n : {16, 64, 128}) {
    const BakeRequest r = sized(blobs, block_bytes(n));
    const lightmap::LightmapMemoryEstimate e = lightmap::estimate_memory(r.lightmap_memory->size);
    ASSERT_EQ(e.medium_bytes.size(), 1u);
    // At least the walk's 2,304 bytes a float leaf (vdb_structure.cpp) for each of the (n / 8)³ leaves.
    const uint64_t leaves = static_cast<uint64_t>(n / 8) * (n / 8) * (n / 8);
    EXPECT_GE(e.media_bytes, leaves * 2304) << n;
    EXPECT_GT(r.memory_bytes, previous) << n;
    previous = r.memory_bytes;
    // The rest of the job is the same whatever the grid.
    if (rest == 0) rest = r.memory_bytes - e.media_bytes;
    EXPECT_EQ(r.memory_bytes - e.media_bytes, rest) << n;
    EXPECT_NE(r.memory_note.find("1 VDB medium ("), std::string::npos) << r.memory_note;
  }
  // 128³ voxels: 4,096 leaves, about 10 MB, more than a 16² lightmap and a 1-triangle mesh: the medium's file is the
  // field to lower. One leaf (0.6 MB, most of it the upper internal node) is less than a 256² lightmap (tens of MB).
  EXPECT_EQ(sized(blobs, block_bytes(128)).memory_field, "job.lightmap.media[0].vdb.file");
  EXPECT_EQ(sized(blobs, block_bytes(8), "", 256).memory_field, "job.lightmap.resolution");
}

TEST(TranslateMedia, AFileTheWalkRefusesIsRefusedWhenSized) {
  test::TempDir dir;
  store::BlobStore blobs(dir.path() / "store");
  const std::string whole = block_bytes(16);
  for (const auto& [bytes, fields, says] :
       {std::tuple{whole, std::string("density_grid: \"smoke\""), std::string("grids[smoke]: no such grid")},
        std::tuple{whole.substr(0, whole.size() / 2), std::string(), std::string("")}}) {
    try {
      sized(blobs, bytes, fields);
      ADD_FAILURE() << "sized " << fields;
    } catch (const InvalidField& e) {
      EXPECT_EQ(e.field(), "job.lightmap.media[0].vdb.file");
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace kiln::daemon
