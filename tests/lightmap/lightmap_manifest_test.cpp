// lightmaps.json against the pages it describes: a scene of several instances (three of one mesh) baked into shared
// atlas pages; each instance's mesh UVs, mapped by the manifest's scale and offset and rasterized as the baker does,
// land on texels that are valid, baked with that instance's light, and no other instance's.
#include "bakers/lightmap/lightmap_bake.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <map>
#include <set>

#include "bakers/image/exr.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/constants.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using Json = nlohmann::json;

using test::translate_scale;

// Under a uniform sky of radiance 1: a 1 m tile in the open (E = π exactly), the same mesh 1.5× inside a closed vault
// that does not bake (E = 0 exactly: no light gets in), the same mesh 0.5× in the open (π), and a ball. The vault
// and the ball are below the open tiles' plane, so that those see nothing but the sky.
scene::Scene sky_scene() {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  const int tile = test::add_quad(s, "tile", {-0.5, 0, 0.5}, {0.5, 0, 0.5}, {0.5, 0, -0.5}, {-0.5, 0, -0.5}, 0, 2);
  s.instances.back().name = "open tile";
  scene::Instance inside;
  inside.mesh = tile;
  inside.name = "tile in the vault";
  inside.to_world = translate_scale({20, -3, 0}, 1.5);
  s.instances.push_back(inside);
  scene::Instance small = inside;
  small.name = "small tile";
  small.to_world = translate_scale({-5, 0, 0}, 0.5);
  s.instances.push_back(small);
  test::add_box(s, "vault", {18, -4, -2}, {22, -1, 2}, 0, /*inward=*/true);
  s.instances.back().bake = false;
  test::add_sphere(s, "ball", {5, -3, 0}, 0.5, 6, 0);
  s.environment.constant = Rgb{1.0};
  return s;
}

TEST(LightmapManifest, EveryInstanceLandsOnItsOwnTexelsAndNoOthers) {
  const scene::Scene s = sky_scene();
  LightmapBakeInput in = test::lightmap_input(s, 16, 0.05);
  in.max_samples = 64;
  in.atlas.texel_density = 16;
  in.atlas.page_size = 48;
  in.atlas.max_pages = 8;
  const LightmapBakeResult result = bake_lightmaps(in);
  const Json manifest = Json::parse(test::find_output(result, "lightmaps.json").bytes);

  ASSERT_EQ(manifest["instances"].size(), s.instances.size());
  const int pages = static_cast<int>(manifest["pages"].size());
  ASSERT_GE(pages, 1);
  // Per page, which instance each texel belongs to (−1: none).
  std::map<std::string, std::vector<int>> owner;
  std::map<std::string, image::FloatImage> irradiance, validity;
  for (const Json& page : manifest["pages"]) {
    const std::string name = page["name"];
    const int size = page["size"];
    owner[name].assign(static_cast<size_t>(size) * size, -1);
    irradiance[name] = test::exr_output(result, name + "_irradiance.exr");
    validity[name] = test::exr_output(result, name + "_validity.exr");
    std::set<std::string> files;
    for (const Json& f : page["files"]) files.insert(f.get<std::string>());
    EXPECT_TRUE(files.count(name + "_irradiance.exr") && files.count(name + "_validity.exr") &&
                files.count(name + "_error.exr"));
    for (const std::string& f : files) EXPECT_NO_THROW(test::find_output(result, f));
  }
  bool shared_by_one_mesh = false;
  for (const Json& page : manifest["pages"]) {
    int tiles = 0;
    for (const Json& i : page["instances"]) tiles += s.instances[i.get<size_t>()].mesh == 0;
    shared_by_one_mesh |= tiles >= 2;
  }
  EXPECT_TRUE(shared_by_one_mesh) << "a page holds two instances of one mesh: " << manifest.dump(1);

  for (size_t i = 0; i < s.instances.size(); ++i) {
    const Json& e = manifest["instances"][i];
    EXPECT_EQ(e["index"], i);
    EXPECT_EQ(e["mesh_name"], s.meshes[s.instances[i].mesh].name);
    if (!s.instances[i].bake) {
      EXPECT_TRUE(e["page"].is_null());
      continue;
    }
    ASSERT_TRUE(e["page"].is_string()) << e.dump();
    if (s.instances[i].name.empty()) {
      EXPECT_FALSE(e.contains("name"));
    } else {
      EXPECT_EQ(e["name"], s.instances[i].name);
    }
    const std::string page = e["page"];
    const int size = manifest["pages"][std::stoi(page.substr(4))]["size"];
    // The instance alone, placed by the manifest's numbers, rasterized as the bake rasterizes.
    scene::Scene solo = s;
    solo.instances = {s.instances[i]};
    solo.instances[0].lightmap = page;
    solo.instances[0].lightmap_scale_offset = {e["scale"][0].get<double>(), e["scale"][1].get<double>(),
                                               e["offset"][0].get<double>(), e["offset"][1].get<double>()};
    RasterOptions raster;
    raster.width = raster.height = size;
    const LightmapTexels texels = rasterize_lightmap(solo, page, raster);
    ASSERT_GT(texels.valid_count(), 0u) << "instance " << i;
    size_t covered = 0, invalid = 0;
    const Json& region = e["region"];
    const int rx = region["x"], ry = region["y"], rw = region["width"], rh = region["height"];
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        if (!texels.valid(x, y)) continue;
        EXPECT_TRUE(x >= rx && x < rx + rw && y >= ry && y < ry + rh) << "instance " << i << " texel " << x << ","
                                                                      << y << " outside its region";
        int& o = owner[page][static_cast<size_t>(y) * size + x];
        EXPECT_EQ(o, -1) << "texel " << x << "," << y << " of " << page << " is instance " << o << "'s and " << i
                         << "'s";
        o = static_cast<int>(i);
        ++covered;
        if (validity[page].at(x, y, 0) != 1.0f) {
          // Leak handling may drop the points of a texel (on the ball, slivers at its poles): the tiles have none.
          EXPECT_EQ(i, 4u) << "instance " << i << " texel " << x << "," << y << " is not valid";
          ++invalid;
          continue;
        }
        const double E = irradiance[page].at(x, y, 1);
        // The tiles' light is exact (a constant sky's estimates are all π; the vault's all 0): float storage, 1e-6.
        if (i == 0 || i == 2) {
          EXPECT_NEAR(E, kPi, 1e-6 * kPi) << "instance " << i << " at " << x << "," << y;
        } else if (i == 1) {
          EXPECT_EQ(E, 0.0) << "the vault's tile at " << x << "," << y;
        } else {
          EXPECT_GT(E, 0.0) << "the ball at " << x << "," << y;
        }
      }
    }
    EXPECT_LE(invalid, covered / 20) << "instance " << i << ": most of its texels are valid";
    // Reached = k·√(A_uv/A_w) with k = 16·√(A_w/A_uv): 16 to rounding.
    EXPECT_NEAR(e["texel_density"].get<double>(), 16.0, 16 * 1e-12) << "no chart clamped at this density";
  }
  // And no texel is valid that no instance put there.
  for (auto& [page, owners] : owner) {
    const int size = validity[page].width;
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        if (validity[page].at(x, y, 0) == 1.0f) {
          EXPECT_GE(owners[static_cast<size_t>(y) * size + x], 0) << page << " texel " << x << "," << y;
        }
      }
    }
  }
  // The report lists the regions too.
  const Json report = Json::parse(test::find_output(result, "report.json").bytes);
  ASSERT_TRUE(report.contains("atlas"));
  EXPECT_EQ(report["atlas"]["pages"], pages);
  EXPECT_EQ(report["atlas"]["regions"].size(), 4u);
  const double efficiency = manifest["efficiency"]["valid_texels"];
  EXPECT_GT(efficiency, 0.0);
  EXPECT_LE(efficiency, 1.0);
}

// Without a density nothing changes: the same outputs as before, no lightmaps.json.
TEST(LightmapManifest, WithoutADensityThereIsNoManifest) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0);
  s.environment.constant = Rgb{1.0};
  const LightmapBakeResult r = bake_lightmaps(test::lightmap_input(s, 8, 0.05));
  for (const bake::BakeOutput& o : r.outputs) EXPECT_NE(o.name, "lightmaps.json");
  EXPECT_NO_THROW(test::find_output(r, "floor_irradiance.exr"));
}

}  // namespace
}  // namespace kiln::lightmap
