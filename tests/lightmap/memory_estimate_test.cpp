// The memory estimate of a lightmap job (memory_estimate.h) against what a bake really holds at its peak: the
// estimate must be at least the measured peak (the daemon's admission relies on it: a job that fits is never killed
// for memory) and not wildly above it (or jobs are refused that would fit). Each test runs in a process of its own
// (ctest runs every test separately), so the process's peak resident size (VmHWM) less its size before the bake is
// the bake's peak.
#include "bakers/lightmap/memory_estimate.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/seams.h"
#include "tests/support/sanitizers.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

// A field of /proc/self/status in kB, as bytes.
uint64_t status_bytes(const std::string& key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind(key + ":", 0) == 0) return std::stoull(line.substr(key.size() + 1)) * 1024;
  }
  return 0;
}

struct Measured {
  uint64_t peak = 0;  // bytes above the process's size before the bake
  LightmapMemoryEstimate estimate;
  uint64_t tracer_bytes = 0;  // what the tracer holds once built (the report's tracer.memory_bytes)
};

Measured measure(const LightmapBakeInput& in, const LightmapJobSize& size) {
  Measured m;
  m.estimate = estimate_memory(size);
  const uint64_t before = status_bytes("VmRSS");
  const LightmapBakeResult r = bake_lightmaps(in);
  m.peak = status_bytes("VmHWM") - before;
  for (const bake::BakeOutput& o : r.outputs) {
    if (o.name != "report.json") continue;
    const size_t tracer = o.bytes.find("\"tracer\"");
    const size_t bytes = o.bytes.find("\"memory_bytes\":", tracer);
    if (tracer != std::string::npos && bytes != std::string::npos)
      m.tracer_bytes = std::stoull(o.bytes.substr(bytes + 15));
  }
  return m;
}

// Sets the job's triangles (count_triangles) and mesh blob bytes (KILNMSH1: float positions, normals and both UV
// sets, the indices) from the scene; returns each mesh's triangles.
std::vector<uint64_t> size_scene(const scene::Scene& s, LightmapJobSize& size) {
  std::vector<uint64_t> mesh_triangles;
  for (const scene::Mesh& mesh : s.meshes) {
    mesh_triangles.push_back(mesh.indices.size() / 3);
    size.mesh_blob_bytes += 20 + mesh.positions.size() * 40 + mesh.indices.size() * 4;
  }
  count_triangles(mesh_triangles, s.instances, size);
  return mesh_triangles;
}

// A floor of 512² texels, with the default outputs and with every output: the texels dominate.
scene::Scene floor_scene() {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0, 2);
  s.environment.constant = Rgb{1.0};
  return s;
}

// The bounds compare resident sizes, which AddressSanitizer inflates (tests/support/sanitizers.h).
class MemoryEstimate : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test::kUnderAddressSanitizer) GTEST_SKIP() << "AddressSanitizer's redzones and shadow add to every allocation";
  }
};

void check_floor(bool every_output) {
  LightmapBakeInput in = test::lightmap_input(floor_scene(), 512, 0.05);
  in.max_samples = 16;
  in.preview = true;
  in.ao = in.directional = in.radiance = in.denoise = every_output;
  LightmapJobSize size;
  size.lightmap_texels = {512 * 512};
  size.traced_triangles = 8;
  size.ao = size.directional = size.radiance = size.denoise = every_output;
  const Measured m = measure(in, size);
  std::printf("512² floor, %s: measured peak %s, estimate %s (%.0f bytes per texel)\n",
              every_output ? "every output" : "default outputs", format_bytes(m.peak).c_str(),
              format_bytes(m.estimate.total).c_str(), m.estimate.bytes_per_texel);
  EXPECT_GE(m.estimate.total, m.peak);
  EXPECT_LE(m.estimate.total, 3 * m.peak) << "an estimate three times the peak refuses jobs that would fit";
}

TEST_F(MemoryEstimate, BoundsTheTexelsOfABigLightmapWithTheDefaultOutputs) { check_floor(false); }
TEST_F(MemoryEstimate, BoundsTheTexelsOfABigLightmapWithEveryOutput) { check_floor(true); }

// A sphere of 359 400 triangles on a small lightmap: the tracer dominates.
TEST_F(MemoryEstimate, BoundsTheTracerOfABigMesh) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_sphere(s, "sphere", {0, 0, 0}, 1.0, 300, 0);
  s.environment.constant = Rgb{1.0};
  LightmapBakeInput in = test::lightmap_input(s, 16, 0.05);
  in.max_samples = 16;
  LightmapJobSize size;
  size.lightmap_texels = {16 * 16};
  size_scene(s, size);
  const Measured m = measure(in, size);
  std::printf("sphere of %llu triangles: measured peak %s (the tracer holds %s once built), estimate %s\n",
              static_cast<unsigned long long>(size.traced_triangles), format_bytes(m.peak).c_str(),
              format_bytes(m.tracer_bytes).c_str(), format_bytes(m.estimate.total).c_str());
  EXPECT_GE(m.estimate.total, m.peak);
  EXPECT_LE(m.estimate.total, 4 * m.peak);
}

// A level's props: one sphere of 57,360 triangles placed 160 times (the first bakes its 16² lightmap, the others only
// cast shadows and bounce light). The tracer holds the sphere once, as an instance of one BVH, and rasterizes only the
// baking one's, so the estimate counts its triangles once for both; counting every copy (as if flattened) would
// ask for 10 GiB where the bake takes about 100 MiB.
TEST_F(MemoryEstimate, BoundsTheTracerOfManyInstancesOfOneMesh) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_sphere(s, "prop", {0, 0, 0}, 1.0, 120, 0);
  s.environment.constant = Rgb{1.0};
  constexpr int kCopies = 160;
  const scene::Instance first = s.instances.front();
  for (int i = 1; i < kCopies; ++i) {
    scene::Instance copy = first;
    copy.to_world = test::translate_scale({3.0 * (i % 8), 0, 3.0 * (i / 8)}, 1.0);
    copy.bake = false;
    s.instances.push_back(copy);
  }
  LightmapBakeInput in = test::lightmap_input(s, 16, 0.05);
  in.max_samples = 16;
  LightmapJobSize size;
  size.lightmap_texels = {16 * 16};
  const std::vector<uint64_t> mesh_triangles = size_scene(s, size);
  EXPECT_EQ(size.traced_triangles, kCopies * mesh_triangles[0]);
  EXPECT_EQ(size.held_triangles, mesh_triangles[0]);
  EXPECT_EQ(size.baked_triangles, mesh_triangles[0]);
  const Measured m = measure(in, size);
  LightmapJobSize flattened = size;
  flattened.held_triangles = flattened.baked_triangles = 0;
  std::printf("%zu instances of %llu triangles: measured peak %s (the tracer holds %s once built), estimate %s "
              "(as if flattened: %s)\n",
              s.instances.size(), static_cast<unsigned long long>(mesh_triangles[0]), format_bytes(m.peak).c_str(),
              format_bytes(m.tracer_bytes).c_str(), format_bytes(m.estimate.total).c_str(),
              format_bytes(estimate_memory(flattened).total).c_str());
  EXPECT_GE(m.estimate.total, m.peak);
  EXPECT_LE(m.estimate.total, 4 * m.peak);
}

// A dense mesh on a small page: 24 baking instances of a 57,360-triangle sphere, each in a cell of 13² texels, about
// 350 triangles a texel. Nearly every triangle gives a sample point of its own (1.1 a triangle), far beyond the 5 a
// texel counted for the texels, and keeps its world-space copy until the points are made: the estimate counts both
// per baking triangle (edge_point_bytes). Seams are not stitched here: their search is bounded on its own below, and
// its bound, for geometry far worse than this, would hide what this test is about.
TEST_F(MemoryEstimate, BoundsTheSamplePointsOfTrianglesSmallerThanATexel) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_sphere(s, "prop", {0, 0, 0}, 1.0, 120, 0);
  s.environment.constant = Rgb{1.0};
  constexpr int kCopies = 24, kCells = 5;
  const scene::Instance first = s.instances.front();
  s.instances.clear();
  for (int i = 0; i < kCopies; ++i) {
    scene::Instance copy = first;
    copy.to_world = test::translate_scale({3.0 * (i % kCells), 0, 3.0 * (i / kCells)}, 1.0);
    copy.lightmap_scale_offset = {1.0 / kCells, 1.0 / kCells, static_cast<double>(i % kCells) / kCells,
                                  static_cast<double>(i / kCells) / kCells};
    s.instances.push_back(copy);
  }
  LightmapBakeInput in = test::lightmap_input(s, 64, 0.05);
  in.min_samples = in.max_samples = 4;
  in.stitch_seams = false;
  LightmapJobSize size;
  size.lightmap_texels = {64 * 64};
  size.seams = false;
  const std::vector<uint64_t> mesh_triangles = size_scene(s, size);
  EXPECT_EQ(size.baked_triangles, kCopies * mesh_triangles[0]);
  const Measured m = measure(in, size);
  std::printf(
      "%d baking instances of %llu triangles on a 64² page: measured peak %s, estimate %s (the points beyond "
      "5 a texel %s)\n",
      kCopies, static_cast<unsigned long long>(mesh_triangles[0]), format_bytes(m.peak).c_str(),
      format_bytes(m.estimate.total).c_str(), format_bytes(m.estimate.edge_point_bytes).c_str());
  EXPECT_GE(m.estimate.total, m.peak);
  EXPECT_LE(m.estimate.total, 4 * m.peak);
}

// A page's seams are held beside its results while the page is written: the largest page's, tiled or not, and not
// at all when seams are not stitched. The stitcher's bound counts on a large page; the search's on a small page of
// many triangles.
TEST(MemoryEstimateModel, CountsTheSeamsOfTheLargestPage) {
  LightmapJobSize job;
  job.lightmap_texels = {2048 * 2048, 512 * 512};
  job.traced_triangles = 1000;
  for (const int tile_size : {0, 256}) {
    LightmapJobSize without = job;
    without.seams = false;
    const double difference = static_cast<double>(estimate_memory(job, tile_size).total) -
                              static_cast<double>(estimate_memory(without, tile_size).total);
    EXPECT_NEAR(difference, static_cast<double>(seam_bytes(2048 * 2048, 1000)), 1.0) << "tile size " << tile_size;
    EXPECT_NEAR(difference, static_cast<double>(SeamStitcher::bytes_bound(2048 * 2048, 3, 4500)), 1.0);
  }
  job.lightmap_texels = {64 * 64};
  job.traced_triangles = 2'000'000;
  job.baked_triangles = 1'000'000;
  LightmapJobSize without = job;
  without.seams = false;
  EXPECT_NEAR(static_cast<double>(estimate_memory(job).total - estimate_memory(without).total),
              static_cast<double>(seam_search_bytes_bound(1'000'000)), 1.0);
  EXPECT_NEAR(seam_search_bytes_per_triangle(), 636, 1) << "the figure memory_estimate.h quotes";
}

}  // namespace
}  // namespace kiln::lightmap
