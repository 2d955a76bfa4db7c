// Atlas packing (bakers/lightmap/atlas_pack.h): regions inside their pages and apart by the padding, densities as
// asked, deterministic, own pages and the page limit, and degenerate scenes that never crash it.
#include "bakers/lightmap/atlas_pack.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bakers/math/constants.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::add_box;
using test::add_quad;
using test::add_sphere;
using test::lambert_material;
using test::translate_scale;

// A quad instanced four times at different scales, a box (six charts in one mesh atlas) and a sphere.
scene::Scene mixed_scene() {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  const int quad = add_quad(s, "quad", {-0.5, 0, 0.5}, {0.5, 0, 0.5}, {0.5, 0, -0.5}, {-0.5, 0, -0.5}, 0, 2);
  s.instances.back().to_world = translate_scale({0, 0, 0}, 2.0);
  for (double scale : {1.0, 0.5, 3.0}) {
    scene::Instance i;
    i.mesh = quad;
    i.to_world = translate_scale({5 * scale, 0, 0}, scale);
    s.instances.push_back(i);
  }
  add_box(s, "box", {2, 0, 2}, {3, 1.5, 3}, 0);
  add_sphere(s, "ball", {-3, 1, 0}, 0.7, 8, 0);
  return s;
}

// Checked without the overlap check, which the packer's placement makes moot (and which is quadratic for many
// instances of one mesh at one place).
scene::CheckedScene checked_scene(const scene::Scene& s) {
  scene::CheckOptions c;
  c.overlaps = false;
  return scene::check_scene(s, c);
}

AtlasPack pack(const scene::Scene& s, const AtlasOptions& o) { return pack_atlas(checked_scene(s), o); }

// Every two regions of a page at least `padding` texels apart along x or y, and each inside its page.
void expect_disjoint_and_inside(const AtlasPack& p) {
  for (size_t a = 0; a < p.regions.size(); ++a) {
    const AtlasRegion& ra = p.regions[a];
    if (ra.page < 0) continue;
    const int size = p.pages[ra.page].size;
    EXPECT_GE(ra.x, 0);
    EXPECT_GE(ra.y, 0);
    EXPECT_LE(ra.x + ra.width, size);
    EXPECT_LE(ra.y + ra.height, size);
    for (size_t b = a + 1; b < p.regions.size(); ++b) {
      const AtlasRegion& rb = p.regions[b];
      if (rb.page != ra.page) continue;
      const bool apart = ra.x + ra.width + p.padding <= rb.x || rb.x + rb.width + p.padding <= ra.x ||
                         ra.y + ra.height + p.padding <= rb.y || rb.y + rb.height + p.padding <= ra.y;
      EXPECT_TRUE(apart) << "regions " << a << " and " << b << " of page " << ra.page << " are closer than "
                         << p.padding << " texels";
    }
  }
}

// The instance's baked triangles mapped by its scale and offset: inside its region (texel space, to 1e-9 texel:
// the rounding of uv·s + o), and their texel area over their world area the density squared (1e-9 relative).
void expect_charts_in_regions(const scene::CheckedScene& checked, const AtlasPack& p) {
  for (const AtlasRegion& r : p.regions) {
    if (r.page < 0) continue;
    const scene::Instance& inst = checked.scene.instances[r.instance];
    const scene::Mesh& mesh = checked.scene.meshes[inst.mesh];
    const double P = p.pages[r.page].size;
    const auto& st = r.scale_offset;
    double texel_area = 0, world_area = 0;
    for (size_t t = 0; t < mesh.indices.size() / 3; ++t) {
      if (!checked.triangles[inst.mesh].bake[t]) continue;
      Point2 q[3];
      Vec3 w[3];
      for (int c = 0; c < 3; ++c) {
        const uint32_t v = mesh.indices[3 * t + c];
        q[c] = {(st[0] * mesh.lightmap_uv[v].x + st[2]) * P, (st[1] * mesh.lightmap_uv[v].y + st[3]) * P};
        w[c] = inst.to_world.point(mesh.positions[v]);
        EXPECT_GE(q[c].x, r.x - 1e-9);
        EXPECT_LE(q[c].x, r.x + r.width + 1e-9);
        EXPECT_GE(q[c].y, r.y - 1e-9);
        EXPECT_LE(q[c].y, r.y + r.height + 1e-9);
      }
      texel_area += 0.5 * std::abs((q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[1].y - q[0].y) * (q[2].x - q[0].x));
      world_area += 0.5 * length(cross(w[1] - w[0], w[2] - w[0]));
    }
    EXPECT_NEAR(std::sqrt(texel_area / world_area) / r.density, 1.0, 1e-9) << "instance " << r.source_instance;
  }
}

TEST(AtlasPack, RegionsAreDisjointInsidePagesAndAtTheDensityAsked) {
  const scene::Scene s = mixed_scene();
  AtlasOptions o;
  o.texel_density = 20;
  o.page_size = 256;
  o.padding = 3;
  const scene::CheckedScene checked = checked_scene(s);
  const AtlasPack p = pack_atlas(checked, o);
  ASSERT_EQ(p.regions.size(), s.instances.size());
  EXPECT_EQ(p.density_scale, 1.0);
  EXPECT_EQ(p.padding, 3);
  for (const AtlasRegion& r : p.regions) {
    ASSERT_GE(r.page, 0) << r.note;
    // No chart is clamped or raised here: the density is the one asked for, to rounding.
    EXPECT_NEAR(r.density / 20.0, 1.0, 1e-12) << "instance " << r.source_instance << " " << r.note;
    EXPECT_TRUE(r.note.empty()) << r.note;
    EXPECT_EQ(r.scale_offset[0], r.scale_offset[1]) << "one scale along u and v";
  }
  // The scale-3 quad (3 m) is 60 texels wide; the 0.5 one 10.
  EXPECT_EQ(p.regions[3].width, 60);
  EXPECT_EQ(p.regions[2].width, 10);
  expect_disjoint_and_inside(p);
  expect_charts_in_regions(checked, p);
  for (const AtlasPage& page : p.pages) EXPECT_EQ(page.name, atlas_page_name(&page - p.pages.data()));
}

TEST(AtlasPack, TheSameSceneGivesTheSamePack) {
  const scene::Scene s = mixed_scene();
  AtlasOptions o;
  o.texel_density = 37.5;
  o.page_size = 128;
  o.max_pages = 64;
  const AtlasPack a = pack(s, o), b = pack(s, o);
  ASSERT_EQ(a.regions.size(), b.regions.size());
  ASSERT_EQ(a.pages.size(), b.pages.size());
  EXPECT_GT(a.pages.size(), 1u) << "several pages, so that the choice of page is exercised";
  for (size_t i = 0; i < a.regions.size(); ++i) {
    EXPECT_EQ(a.regions[i].page, b.regions[i].page);
    EXPECT_EQ(a.regions[i].x, b.regions[i].x);
    EXPECT_EQ(a.regions[i].y, b.regions[i].y);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(a.regions[i].scale_offset[k], b.regions[i].scale_offset[k]);
  }
  expect_disjoint_and_inside(a);
}

TEST(AtlasPack, PerInstanceDensityAndOwnPage) {
  const scene::Scene s = mixed_scene();
  AtlasOptions o;
  o.texel_density = 10;
  o.page_size = 512;
  o.instances[1].texel_density = 40;  // the first unscaled copy of the quad
  o.instances[4].own_page = true;     // the box
  const AtlasPack p = pack(s, o);
  EXPECT_NEAR(p.regions[1].density, 40, 40 * 1e-12);
  EXPECT_NEAR(p.regions[0].density, 10, 10 * 1e-12);
  EXPECT_EQ(p.regions[1].width, 40);
  const int box_page = p.regions[4].page;
  ASSERT_GE(box_page, 0);
  EXPECT_TRUE(p.pages[box_page].own_page);
  ASSERT_EQ(p.pages[box_page].regions.size(), 1u) << "the box's page holds the box alone";
  for (size_t i = 0; i < p.regions.size(); ++i) {
    if (i != 4) {
      EXPECT_NE(p.regions[i].page, box_page);
    }
  }
  EXPECT_EQ(p.pages.size(), 2u);
}

// Each page shrinks to the smallest square (a multiple of 4 texels) that holds its charts; the densities and chart
// sizes stay; with uniform_pages every page keeps page_size. An own page is its chart and padding, rounded up to 4.
TEST(AtlasPack, PagesShrinkToTheirChartsUnlessUniform) {
  const scene::Scene s = mixed_scene();
  AtlasOptions o;
  o.texel_density = 10;
  o.page_size = 512;
  o.instances[4].own_page = true;  // the box
  const scene::CheckedScene checked = checked_scene(s);
  const AtlasPack shrunk = pack_atlas(checked, o);
  o.uniform_pages = true;
  const AtlasPack uniform = pack_atlas(checked, o);
  ASSERT_EQ(shrunk.pages.size(), uniform.pages.size());
  for (const AtlasPage& page : uniform.pages) EXPECT_EQ(page.size, 512);
  double page_texels = 0, uniform_texels = 0;
  for (size_t p = 0; p < shrunk.pages.size(); ++p) {
    const AtlasPage& page = shrunk.pages[p];
    EXPECT_EQ(page.size % 4, 0);
    EXPECT_LT(page.size, 512) << page.name << " holds a few small charts";
    // No square smaller than the charts' padded area holds them.
    double padded = 0;
    for (uint32_t r : page.regions) {
      const AtlasRegion& region = shrunk.regions[r];
      padded += static_cast<double>(region.width + shrunk.padding) * (region.height + shrunk.padding);
    }
    EXPECT_GE(page.size, std::sqrt(padded));
    page_texels += static_cast<double>(page.size) * page.size;
    uniform_texels += 512.0 * 512.0;
  }
  for (size_t i = 0; i < shrunk.regions.size(); ++i) {
    const AtlasRegion &a = shrunk.regions[i], &b = uniform.regions[i];
    EXPECT_EQ(a.page, b.page);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.density, b.density);
  }
  const AtlasRegion& box = shrunk.regions[4];
  const int own = shrunk.pages[box.page].size;
  EXPECT_EQ(own, (std::max(box.width, box.height) + shrunk.padding + 3) / 4 * 4);
  EXPECT_EQ(box.x, shrunk.padding / 2);
  EXPECT_LT(page_texels, uniform_texels / 4);
  expect_disjoint_and_inside(shrunk);
  expect_charts_in_regions(checked, shrunk);
  expect_disjoint_and_inside(uniform);
  expect_charts_in_regions(checked, uniform);
}

// A chart larger than a page is shrunk to fit it, and says so.
TEST(AtlasPack, AChartLargerThanAPageIsClampedAndReported) {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  add_quad(s, "field", {-50, 0, 50}, {50, 0, 50}, {50, 0, -50}, {-50, 0, -50}, 0);
  AtlasOptions o;
  o.texel_density = 10;  // 1000 texels asked for
  o.page_size = 256;
  o.padding = 4;
  const AtlasPack p = pack(s, o);
  ASSERT_EQ(p.regions.size(), 1u);
  EXPECT_EQ(p.regions[0].width, 252);
  EXPECT_EQ(p.regions[0].height, 252);
  EXPECT_NEAR(p.regions[0].density, 2.52, 1e-9);
  EXPECT_NE(p.regions[0].note.find("reduced"), std::string::npos) << p.regions[0].note;
  expect_disjoint_and_inside(p);
}

// More charts than max_pages hold: every density scaled by one factor, the largest (to 2⁻²⁰) that fits.
TEST(AtlasPack, MorePagesThanAllowedScaleTheDensityDownToFit) {
  const scene::Scene s = mixed_scene();
  AtlasOptions o;
  o.texel_density = 60;
  o.page_size = 128;
  o.max_pages = 64;
  const size_t unlimited = pack(s, o).pages.size();
  ASSERT_GT(unlimited, 2u);
  o.max_pages = 2;
  const scene::CheckedScene checked = checked_scene(s);
  const AtlasPack p = pack_atlas(checked, o);
  EXPECT_LE(p.pages.size(), 2u);
  EXPECT_LT(p.density_scale, 1.0);
  EXPECT_GT(p.density_scale, 0.1);
  for (const AtlasRegion& r : p.regions) {
    ASSERT_GE(r.page, 0);
    EXPECT_LE(r.density, 60 * p.density_scale * (1 + 1e-12) + 1e-9);
  }
  expect_disjoint_and_inside(p);
  expect_charts_in_regions(checked, p);
  // A factor 2⁻¹⁹ above it does not fit (bisection to 2⁻²⁰ of a monotone-enough search: within two steps).
  AtlasOptions more = o;
  more.texel_density = 60 * (p.density_scale + 0x1.0p-18);
  more.max_pages = 64;
  EXPECT_GT(pack(s, more).pages.size(), 2u);
}

TEST(AtlasPack, ChartsThatCannotFitEvenAtOneTexelNameMaxPages) {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  const int quad = add_quad(s, "tile", {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, 0);
  for (int i = 1; i < 200; ++i) {
    scene::Instance inst;
    inst.mesh = quad;
    inst.to_world = translate_scale({2.0 * i, 0, 0}, 1);
    s.instances.push_back(inst);
  }
  AtlasOptions o;
  o.texel_density = 1;
  o.page_size = 16;  // 16 cells of 1 + 3 texels: 200 instances need 13 pages
  o.padding = 3;
  o.max_pages = 4;
  try {
    pack(s, o);
    FAIL() << "no error";
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "max_pages");
    EXPECT_NE(e.problem().find("200 instances"), std::string::npos) << e.problem();
  }
  o.max_pages = 13;
  const AtlasPack p = pack(s, o);
  EXPECT_EQ(p.pages.size(), 13u);
  expect_disjoint_and_inside(p);
}

// A zero-area mesh, a mesh without lightmap UVs, NaN positions and UVs, a NaN transform, an empty scene: no crash,
// no region for what cannot be baked, and the others still packed.
TEST(AtlasPack, DegenerateInputsNeverCrash) {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  add_quad(s, "good", {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, 0);
  const int flat = add_quad(s, "point", {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 0);
  const int no_uv = add_quad(s, "no_uv", {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, 0);
  s.meshes[no_uv].lightmap_uv.clear();
  const int nan = add_quad(s, "nan", {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, 0, 2);
  s.meshes[nan].positions[0].x = std::numeric_limits<double>::quiet_NaN();
  s.meshes[nan].lightmap_uv[3].y = std::numeric_limits<double>::quiet_NaN();
  const int same_uv = add_quad(s, "same_uv", {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, 0);
  for (Point2& uv : s.meshes[same_uv].lightmap_uv) uv = {0.5, 0.5};
  scene::Instance bad;
  bad.mesh = 0;
  bad.to_world.m[0] = std::numeric_limits<double>::quiet_NaN();
  s.instances.push_back(bad);
  (void)flat;
  AtlasOptions o;
  o.texel_density = 16;
  o.page_size = 64;
  const scene::CheckedScene checked = checked_scene(s);
  const AtlasPack p = pack_atlas(checked, o);
  int packed = 0;
  for (const AtlasRegion& r : p.regions) {
    if (r.page >= 0) {
      ++packed;
      EXPECT_TRUE(std::isfinite(r.density));
      for (double v : r.scale_offset) EXPECT_TRUE(std::isfinite(v));
    }
  }
  EXPECT_GE(packed, 2) << "the good quad and what the check left of the NaN one";
  expect_disjoint_and_inside(p);
  expect_charts_in_regions(checked, p);

  // A quad as thin as a hair: a chart of one texel at least, reported as raised.
  scene::Scene thin;
  thin.materials.push_back(lambert_material("grey", 0.5));
  add_quad(thin, "hair", {0, 0, 1e-7}, {1e-7, 0, 1e-7}, {1e-7, 0, 0}, {0, 0, 0}, 0);
  const AtlasPack t = pack(thin, o);
  ASSERT_EQ(t.regions.size(), 1u);
  EXPECT_EQ(t.regions[0].width, 1);
  EXPECT_NE(t.regions[0].note.find("raised"), std::string::npos);

  EXPECT_TRUE(pack(scene::Scene{}, o).pages.empty());

  AtlasOptions bad_options = o;
  bad_options.texel_density = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(pack(s, bad_options), bake::InvalidInput);
  bad_options = o;
  bad_options.instances[0].texel_density = -1;
  try {
    pack(s, bad_options);
    FAIL();
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "instances[0].texel_density");
  }
}

// check_and_pack_scene: the placement the packer replaces is not reported as overlapping; a mesh whose own UVs
// overlap still is.
TEST(AtlasPack, OverlapsAreCheckedOnThePagesAsBaked) {
  scene::Scene s = mixed_scene();  // four instances of one quad at the same default place: overlapping
  s.meshes[0].name = "Node/quad";   // not a file name: renamed when it names a lightmap, not when pages do
  EXPECT_GT(scene::check_scene(s).report.count(scene::ProblemKind::overlapping_lightmap_uv), 0);
  EXPECT_GT(scene::check_scene(s).report.count(scene::ProblemKind::renamed_lightmap), 0);
  AtlasOptions o;
  o.texel_density = 20;
  o.page_size = 256;
  AtlasPack p;
  const scene::CheckedScene packed = check_and_pack_scene(s, o, {}, p);
  EXPECT_EQ(packed.report.count(scene::ProblemKind::overlapping_lightmap_uv), 0);
  EXPECT_EQ(packed.report.count(scene::ProblemKind::renamed_lightmap), 0);
  EXPECT_TRUE(packed.renamed_lightmaps.empty());
  for (const scene::Instance& inst : packed.scene.instances) EXPECT_EQ(inst.lightmap.rfind("page", 0), 0u);

  // A quad whose two triangles share the same UVs overlaps itself, wherever it is placed.
  scene::Scene folded;
  folded.materials.push_back(lambert_material("grey", 0.5));
  add_quad(folded, "folded", {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, 0);
  // Vertices (0, 0), (1, 0), (0, 1), (1, 1) of the grid; triangles {0, 1, 3} and {0, 3, 2}: the second folded onto
  // the first.
  folded.meshes[0].lightmap_uv = {{0, 1}, {1, 1}, {1, 1}, {1, 0}};
  AtlasPack q;
  const scene::CheckedScene f = check_and_pack_scene(folded, o, {}, q);
  EXPECT_GT(f.report.count(scene::ProblemKind::overlapping_lightmap_uv), 0);
}

// The bundled Cornell box (test::cornell_box(), the example's geometry and lightmap UVs): how full its pages are,
// printed for docs/LIGHTMAP.md: charts (their triangles' texels), their rectangles, and those with padding, over the
// pages' texels.
TEST(AtlasPack, CornellBoxEfficiency) {
  const scene::Scene s = test::cornell_box();
  auto report = [&](double density, int size, int max_pages) {
    AtlasOptions o;
    o.texel_density = density;
    o.page_size = size;
    o.padding = 4;
    o.max_pages = max_pages;
    const AtlasPack p = pack(s, o);
    double charts = 0, rects = 0, padded = 0;
    for (const AtlasRegion& r : p.regions) {
      charts += r.chart_texels;
      rects += static_cast<double>(r.width) * r.height;
      padded += static_cast<double>(r.width + p.padding) * (r.height + p.padding);
    }
    double page_texels = 0;
    for (const AtlasPage& page : p.pages) page_texels += static_cast<double>(page.size) * page.size;
    std::printf("%7.2f texels/m, %4d^2 pages: %zu pages, charts %5.1f %%, chart rectangles %5.1f %%, with padding "
                "%5.1f %%\n",
                density * p.density_scale, size, p.pages.size(), 100 * charts / page_texels,
                100 * rects / page_texels, 100 * padded / page_texels);
    expect_disjoint_and_inside(p);
    return charts / page_texels;
  };
  for (double d : {16.0, 32.0, 36.0, 54.0, 64.0}) report(d, 256, 64);
  // The highest density that fits one page (far more asked for, scaled down to fit). Five equal 2 m walls make 80 %
  // of the box's surface and a square page holds them three to a row: at 37.6 texels/m the walls (75 + 4 texels)
  // take 5 of 3 × 2 cells, 43 % of the page, and the blocks and the light add 11 %, so 54.6 % is what any packer of
  // whole instances reaches here; 0.5 leaves room for rounding, and fails if the packer wastes a cell.
  EXPECT_GE(report(1e4, 256, 1), 0.5);
  EXPECT_GE(report(1e4, 1024, 1), 0.5);
}

}  // namespace
}  // namespace kiln::lightmap
