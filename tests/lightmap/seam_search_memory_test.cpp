// The seam search's memory (seams.h: seam_search_bytes_bound) against what it allocates, counted by replacing the
// global operator new in this program: the bound is of the bytes the search holds, whatever the geometry, so it is
// checked on the geometry that costs the search most rather than on a bake's resident size (in which the allocator's
// pages kept after a free, and the rest of the bake, would blur it).
#include <gtest/gtest.h>

#include <malloc.h>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>

#include "bakers/lightmap/seams.h"
#include "tests/support/test_scenes.h"

namespace {

// Live bytes allocated through operator new, as malloc holds them (malloc_usable_size: the size asked for, rounded up
// to malloc's granule), and the most at once since the last reset. No header is added to a block, so the pointers
// the program keeps are malloc's own (LeakSanitizer finds what libraries keep by them).
std::atomic<std::size_t> g_live{0}, g_peak{0};

void* allocate(std::size_t size) noexcept {
  void* p = std::malloc(size == 0 ? 1 : size);
  if (!p) return nullptr;
  const std::size_t bytes = malloc_usable_size(p);
  const std::size_t live = g_live.fetch_add(bytes, std::memory_order_relaxed) + bytes;
  std::size_t peak = g_peak.load(std::memory_order_relaxed);
  while (live > peak && !g_peak.compare_exchange_weak(peak, live, std::memory_order_relaxed)) {
  }
  return p;
}

void release(void* p) noexcept {
  if (!p) return;
  g_live.fetch_sub(malloc_usable_size(p), std::memory_order_relaxed);
  std::free(p);
}

}  // namespace

// Every form but the aligned ones (which the sanitizers' runtime serves and frees itself), so that no block is freed
// by a form that did not allocate it. Out of line, so that GCC does not inline malloc/free pairs into callers and then
// warn that new and free mismatch.
[[gnu::noinline]] void* operator new(std::size_t size) {
  if (void* p = allocate(size)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void* operator new[](std::size_t size) { return operator new(size); }
[[gnu::noinline]] void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return allocate(size); }
[[gnu::noinline]] void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return allocate(size); }
[[gnu::noinline]] void operator delete(void* p) noexcept { release(p); }
[[gnu::noinline]] void operator delete[](void* p) noexcept { release(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { release(p); }
[[gnu::noinline]] void operator delete[](void* p, std::size_t) noexcept { release(p); }
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
[[gnu::noinline]] void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }

namespace kiln::lightmap {
namespace {

// A cell of a grid of `cells`² in UV space: where triangle `i` of a mesh gets lightmap UVs of its own.
std::array<Point2, 3> own_chart(std::size_t i, std::size_t cells) {
  const double x = static_cast<double>(i % cells) / cells, y = static_cast<double>(i / cells) / cells;
  const double c = 0.8 / cells;
  return {Point2{x + 0.1 * c, y + 0.1 * c}, Point2{x + c, y + 0.1 * c}, Point2{x + 0.1 * c, y + c}};
}

// One mesh named "page" of unindexed triangles, built by add(world corners, lightmap UVs).
struct PageMesh {
  scene::Mesh mesh;
  PageMesh() { mesh.name = "page"; }
  void add(const std::array<Vec3, 3>& p, const std::array<Point2, 3>& uv) {
    for (int k = 0; k < 3; ++k) {
      mesh.indices.push_back(static_cast<uint32_t>(mesh.positions.size()));
      mesh.positions.push_back(p[k]);
      mesh.lightmap_uv.push_back(uv[k]);
    }
  }
  std::size_t triangles() const { return mesh.indices.size() / 3; }
  scene::Scene scene() && {
    scene::Scene s;
    s.materials.push_back(test::lambert_material("grey", 0.5));
    s.meshes.push_back(std::move(mesh));
    s.instances.push_back({});
    return s;
  }
};

// The most bytes find_seams held at once on `s`, the seams it returns included.
std::size_t search_peak(const scene::Scene& s, std::size_t triangles, SeamSearch& found) {
  const std::size_t before = g_live.load();
  g_peak.store(before);
  found = find_seams(s, "page", 4096, 4096);
  const std::size_t peak = g_peak.load() - before;
  std::printf(
      "%zu triangles, %zu seams (%.2f a triangle): held at most %.1f MB (%.0f bytes a triangle), bound %.1f "
      "MB\n",
      triangles, found.seams.size(), static_cast<double>(found.seams.size()) / triangles, peak / 1e6,
      static_cast<double>(peak) / triangles, seam_search_bytes_bound(triangles) / 1e6);
  return peak;
}

// Triangles whose corners are all points of their own in world space (a soup: three welded points a triangle, the
// welder's most), and no seam.
TEST(SeamSearchMemory, TriangleSoupStaysWithinTheBound) {
  constexpr std::size_t kTriangles = 400'000;
  PageMesh page;
  const auto cells = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(kTriangles))));
  for (std::size_t i = 0; i < kTriangles; ++i) {
    const double x = static_cast<double>(i);
    page.add({Vec3{x, 0, 0}, Vec3{x + 0.3, 1, 0}, Vec3{x + 0.6, 0, 1}}, own_chart(i, cells));
  }
  const scene::Scene s = std::move(page).scene();
  SeamSearch found;
  const std::size_t peak = search_peak(s, kTriangles, found);
  EXPECT_EQ(found.seams.size(), 0u);
  EXPECT_EQ(found.shared_edges, 0u);
  EXPECT_LE(peak, seam_search_bytes_bound(kTriangles));
}

// A double-layered grid whose every triangle has a chart of its own: every inner edge is on four sides with six seams
// among them, 4.5 seams a triangle less the border's (the listing's most).
TEST(SeamSearchMemory, FourSidedEdgesStayWithinTheBound) {
  constexpr std::size_t kSide = 200, kTriangles = 4 * kSide * kSide;
  PageMesh page;
  const auto cells = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(kTriangles))));
  for (std::size_t i = 0; i < kSide * kSide; ++i) {
    const double x = static_cast<double>(i % kSide), z = static_cast<double>(i / kSide);
    const Vec3 a{x, 0, z}, b{x + 1, 0, z}, c{x + 1, 0, z + 1}, d{x, 0, z + 1};
    for (int layer = 0; layer < 2; ++layer) {
      page.add({a, b, c}, own_chart(page.triangles(), cells));
      page.add({a, c, d}, own_chart(page.triangles(), cells));
    }
  }
  const scene::Scene s = std::move(page).scene();
  SeamSearch found;
  const std::size_t peak = search_peak(s, kTriangles, found);
  EXPECT_GT(found.seams.size(), 4 * kTriangles);
  EXPECT_EQ(found.non_manifold, found.edges - 4 * kSide);  // every edge but the border's is on four sides
  EXPECT_LE(peak, seam_search_bytes_bound(kTriangles));
}

}  // namespace
}  // namespace kiln::lightmap
