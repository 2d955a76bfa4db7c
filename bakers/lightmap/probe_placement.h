// Where light probes go (docs/PROBES.md): a lattice of `spacing` over the regions (a probe at the centre of every
// cell, counted from the regions' lowest corner), kept only within max_distance of a triangle of the scene, so that
// the probes stored are those a renderer interpolates near geometry (sparse, as OpenVDB stores them). When the
// probes near geometry would exceed max_probes, or the lattice would exceed 2^20 points along an axis, the spacing
// doubles until they fit, and the placement says why.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "bakers/bake/stop.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

struct ProbeBox {
  Vec3 lo, hi;
};

struct ProbePlacementOptions {
  std::vector<ProbeBox> regions;  // empty: the triangles' bounding box grown by max_distance
  double spacing = 1;             // > 0
  double max_distance = 2;        // ≥ 0
  uint64_t max_probes = uint64_t{1} << 18;
};

struct ProbePlacement {
  Vec3 origin;         // the world position of lattice index (0, 0, 0): the lowest corner plus half a spacing
  double spacing = 0;  // as placed (the options' or doubled)
  std::vector<std::array<int, 3>> voxels;  // the probes' lattice indices, sorted (k, j, i)
  std::vector<Vec3> positions;             // their world positions
  std::vector<ProbeBox> regions;           // as used
  uint64_t lattice_points = 0;             // in the regions at the final spacing
  uint64_t skipped_far = 0;                // of them, farther than max_distance from every triangle
  int doublings = 0;                       // of the spacing
  std::vector<std::string> reasons;        // the decisions and why, for people
};

// Throws bake::OutOfTime or bake::BakeCancelled as `stop` says (it is polled every few triangles).
ProbePlacement place_probes(const scene::Scene& scene, const ProbePlacementOptions& options,
                            const bake::StopCheck& stop);

// The distance from p to triangle (a, b, c), exact (Ericson, Real-Time Collision Detection, 5.1.5); a degenerate
// triangle is its segments'.
double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace kiln::lightmap
