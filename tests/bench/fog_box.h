// The scene of the media and probe benchmarks: the bundled Cornell box (tests/support/test_scenes.h) under its
// ceiling patch and the low sun through its open side of client/examples/scenes/cornell_box_fog.textproto, and that
// example's fog filling the box (sigma_a 0.02, sigma_s 0.16-0.2 per metre, g 0.6).
#pragma once

#include "bakers/volume/grid_medium.h"
#include "bakers/volume/medium_input.h"
#include "tests/support/test_scenes.h"
#include "tests/volume/media_test_util.h"

namespace kiln::bench {

inline scene::Scene cornell_box_with_sun() {
  scene::Scene s = test::cornell_box();
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(Vec3{0.25, -0.45, -1});
  sun.angular_diameter = 0.00935;
  sun.color = Rgb{6, 5.6, 5};
  s.lights.push_back(sun);
  return s;
}

inline volume::MediumInput example_fog() {
  volume::HomogeneousMediumSpec spec;
  spec.sigma_a = Rgb{0.02};
  spec.sigma_s = Rgb{0.16, 0.18, 0.2};
  spec.g = 0.6;
  spec.box = volume::Bounds3{{-1, 0, -1}, {1, 2, 1}};
  volume::MediumInput fog;
  fog.name = "fog";
  fog.spec = spec;
  return fog;
}

// A heterogeneous medium from a VDB grid: the media tests' lumpy ball (density up to about 6, zero outside its
// ball) scaled to 1.2 m and hung in the middle of the box, sigma_a 0.3 and sigma_s 1.2 per unit density (up to
// about 9 per metre at its densest), g 0.3: a cloud of smoke that the box's light crosses in places.
inline volume::MediumInput example_smoke() {
  volume::GridMediumSpec spec;
  spec.density = volume::test::lumpy_ball_grid();
  spec.to_world.m = {1.2, 0, 0, -0.6, 0, 1.2, 0, 0.3, 0, 0, 1.2, -0.6};
  spec.sigma_a = Rgb{0.3};
  spec.sigma_s = Rgb{1.2};
  spec.g = 0.3;
  volume::MediumInput smoke;
  smoke.name = "smoke";
  smoke.spec = spec;
  return smoke;
}

}  // namespace kiln::bench
