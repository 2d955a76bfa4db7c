// Charts of a mesh for lightmap-UV generation: the mesh's usable triangles, their adjacency across edges that may lie
// inside a chart, and the split of the triangles into charts by region growing (as xatlas does).
//
// ## Which edges a chart may span
// Positions are welded (bitwise-equal positions are one vertex), so an edge two triangles share in space is shared
// even where the mesh split its vertices for normals or texture UVs. An edge joins two triangles that run it in
// opposite directions (where more than two meet, each is paired with the opposite-running one whose normal is closest),
// unless it is cut. Cut edges are:
//   - hard edges: the dihedral angle exceeds `hard_angle_degrees`, or the mesh gives the two triangles different
//     normals at a shared position (the exporter's split normals: an artist's hard edge);
//   - texture seams (with `split_at_texture_seams`): different texture UVs at a shared position. Cutting there puts
//     the lightmap's seams where the texture's already are, so the two kinds of seam coincide.
//
// ## Region growing
// Seeds are taken largest triangle first (ties by index). A chart grows across its uncut edges, cheapest candidate
// first, the cost being the deviation of the candidate's normal from the chart's area-weighted mean normal; a
// candidate joins when that deviation is at most `max_normal_deviation_degrees`, which bounds how far the chart is
// from a plane (and so its distortion when flattened). Everything is ordered by (cost, triangle index): the same mesh
// gives the same charts.
//
// Unusable triangles (an index out of range, a non-finite position, zero area in 3-D: what the scene check drops)
// are in no chart.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "bakers/math/vec3.h"
#include "bakers/scene/scene.h"

namespace kiln::uvgen {

struct ChartOptions {
  double max_normal_deviation_degrees = 50;  // from the chart's mean normal
  double hard_angle_degrees = 70;            // a dihedral angle above this cuts the edge
  bool split_at_texture_seams = true;
};

// Whether a triangle with these corners can be charted: finite, and not flat at float precision (the scene check's
// test: |e1 × e2| > 2⁻²⁰ ℓ², ℓ the longest edge), so the bake keeps it. Its unit normal and area when it can.
bool chartable(const Vec3& p0, const Vec3& p1, const Vec3& p2, Vec3* normal = nullptr, double* area = nullptr);

// A chart: triangle indices of the mesh (indices[3t..3t+2]), ascending.
using Chart = std::vector<uint32_t>;

class MeshAdjacency {
 public:
  MeshAdjacency(const scene::Mesh& mesh, const ChartOptions& options);

  const scene::Mesh& mesh() const { return mesh_; }
  size_t triangle_count() const { return usable_.size(); }  // of the mesh, usable or not
  bool usable(uint32_t t) const { return usable_[t] != 0; }
  const Vec3& normal(uint32_t t) const { return normal_[t]; }  // unit; zero for an unusable triangle
  double area(uint32_t t) const { return area_[t]; }
  // The triangle across edge e (corners e, e+1) when the edge may lie inside a chart, else -1.
  int64_t neighbour(uint32_t t, int e) const { return neighbour_[t][e]; }
  // The welded vertex of corner c of triangle t: equal for equal positions.
  uint32_t welded(uint32_t t, int c) const { return welded_[mesh_.indices[3 * t + c]]; }
  size_t welded_count() const { return welded_count_; }

 private:
  const scene::Mesh& mesh_;
  std::vector<uint8_t> usable_;
  std::vector<Vec3> normal_;
  std::vector<double> area_;
  std::vector<std::array<int64_t, 3>> neighbour_;
  std::vector<uint32_t> welded_;
  size_t welded_count_ = 0;
};

// Every usable triangle in exactly one chart; charts in the order their seeds were taken.
std::vector<Chart> grow_charts(const MeshAdjacency& adjacency, const ChartOptions& options);

// The connected pieces of `triangles` (joined across uncut edges), each ascending, ordered by their first triangle.
std::vector<Chart> connected_pieces(const MeshAdjacency& adjacency, const Chart& triangles);

// A chart cut in two across its longest extent (at the median of its triangles' centroids along it), then into
// connected pieces: what the generator does with a chart it could not flatten well. A chart of one triangle is
// returned as it is.
std::vector<Chart> split_chart(const MeshAdjacency& adjacency, const Chart& chart);

}  // namespace kiln::uvgen
