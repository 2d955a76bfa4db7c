// Flattening one chart (mesh_charts.h) into the plane for lightmap UVs.
//
// In order, the first that gives every triangle a positive (counter-clockwise) UV area, an L2 stretch (uv_quality.h)
// of at most `max_l2_stretch` over the chart, and no two triangles overlapping (a border that crosses itself, as a
// free border may; by the scene check's test):
//   1. a single triangle: laid out isometrically (stretch 1, angle error 0);
//   2. least-squares conformal maps (Lévy et al. 2002, CGAL's LSCM_parameterizer_3, two border vertices pinned): the
//      conformal map closest to the chart's angles, free border;
//   3. the orthogonal projection onto the plane across the chart's mean normal, which region growing keeps within
//      max_normal_deviation of every triangle's normal, so no triangle flips (what a chart CGAL cannot handle gets:
//      a non-manifold vertex, a solver that did not converge).
// Otherwise none: the generator splits the chart (split_chart) and flattens the pieces. The UVs are in surface units:
// the chart's UV area equals its surface area, so charts keep their relative sizes for packing.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "bakers/math/sampling.h"
#include "bakers/uvgen/mesh_charts.h"

namespace kiln::uvgen {

enum class FlattenMethod { single, lscm, projection };
const char* to_string(FlattenMethod method);

struct FlattenOptions {
  double max_l2_stretch = 1.25;
};

struct FlatChart {
  Chart triangles;
  std::vector<std::array<Point2, 3>> uv;  // per triangle of `triangles`, its corners' UVs
  FlattenMethod method = FlattenMethod::single;
  double l2_stretch = 1;
  double mean_angle_error_degrees = 0;
};

std::optional<FlatChart> flatten_chart(const MeshAdjacency& adjacency, const Chart& chart,
                                       const FlattenOptions& options);

}  // namespace kiln::uvgen
