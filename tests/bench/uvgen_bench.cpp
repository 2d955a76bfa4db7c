// The lightmap-UV generator's quality and speed (bakers/uvgen/, docs/UVGEN.md): for the bundled Cornell box's meshes
// (client/examples/scenes/cornell_box.py, as tests/support/test_scenes.h builds it) and the generated set (a torus,
// a sphere, a character-like blob, a room with furniture, a 100k-triangle scan-like mesh), each packed into a
// SIZE² square with 4 texels of padding, it prints per mesh: triangles, charts (and how many LSCM flattened),
// rounds of re-splitting overlapping charts, the utilisation of the square, the L2 stretch (Sander et al. 2001,
// 1 is best), the mean angle error in degrees, overlapping pairs (must be 0), the seconds and the seconds per
// 100k triangles.
//
//
// --obj=FILE (repeatable) adds a Wavefront OBJ of positions, normals and polygons (fan-triangulated; a vertex per
// distinct position and normal, as an importer makes them): xatlas's test meshes (its models/ folder: cube.obj,
// double_sided.obj, gazebo.obj), whose chart counts its own test asserts, compare with it.
//
//   uvgen_bench [--size=1024] [--table_out=FILE] [--obj=FILE ...]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/uvgen/uv_generator.h"
#include "tests/bench/table_file.h"
#include "tests/support/test_scenes.h"
#include "tests/support/uv_shapes.h"

using namespace kiln;

namespace {

// Positions, normals and faces of an OBJ (texture coordinates, groups and materials ignored).
scene::Mesh read_obj(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<Vec3> v, vn;
  std::map<std::pair<long, long>, uint32_t> vertex;  // (position, normal) → vertex
  scene::Mesh m;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v" || tag == "vn") {
      Vec3 p;
      s >> p.x >> p.y >> p.z;
      (tag == "v" ? v : vn).push_back(p);
    } else if (tag == "f") {
      std::vector<uint32_t> face;
      std::string word;
      while (s >> word) {
        const long pi = std::stol(word) - 1;
        const size_t last = word.rfind('/');
        const long ni = last != std::string::npos && word.find('/') != last ? std::stol(word.substr(last + 1)) - 1 : -1;
        auto [it, fresh] = vertex.emplace(std::make_pair(pi, ni), static_cast<uint32_t>(m.positions.size()));
        if (fresh) {
          m.positions.push_back(v.at(static_cast<size_t>(pi)));
          if (ni >= 0) m.normals.push_back(vn.at(static_cast<size_t>(ni)));
        }
        face.push_back(it->second);
      }
      for (size_t k = 2; k < face.size(); ++k) m.indices.insert(m.indices.end(), {face[0], face[k - 1], face[k]});
    }
  }
  if (m.normals.size() != m.positions.size()) m.normals.clear();
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  int size = 1024;
  std::string table_out;
  std::vector<std::string> objs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--size=", 0) == 0) {
      size = std::atoi(a.c_str() + 7);
    } else if (a.rfind("--obj=", 0) == 0) {
      objs.push_back(a.substr(6));
    } else if (a.rfind("--table_out=", 0) == 0) {
      table_out = a.substr(12);
    } else {
      std::fprintf(stderr, "unknown argument %s; see the top of uvgen_bench.cpp\n", a.c_str());
      return 2;
    }
  }
  std::vector<test::NamedMesh> meshes;
  const scene::Scene cornell = test::cornell_box();
  for (const scene::Mesh& m : cornell.meshes) meshes.push_back({"cornell/" + m.name, m});
  for (test::NamedMesh& m : test::uv_generated_set()) meshes.push_back(std::move(m));
  for (const std::string& path : objs) meshes.push_back({path.substr(path.rfind('/') + 1), read_obj(path)});

  uvgen::UvgenOptions options;
  options.pack.size = size;
  options.pack.padding = 4;
  char line[512];
  std::string table;
  std::snprintf(line, sizeof line,
                "| mesh | triangles | charts (LSCM / projected / single) | rounds | utilisation | "
                "L2 stretch | angle error (°) | overlaps | seconds | CPU s / 100k triangles |\n");
  table += line;
  table += "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const test::NamedMesh& m : meshes) {
    // CPU time as well as wall time: on a shared machine the wall clock measures the other processes too.
    const std::clock_t c0 = std::clock();
    const uvgen::GeneratedUvs g = uvgen::generate_lightmap_uvs(m.mesh, options);
    const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    const uvgen::UvgenStats& s = g.stats;
    const double per_100k = cpu / std::max<double>(1, static_cast<double>(s.quality.triangles)) * 1e5;
    std::snprintf(line, sizeof line,
                  "| %s | %lld | %d (%d / %d / %d) | %d | %.3f | %.4f | %.2f | %lld | %.3f | %.2f |\n", m.name.c_str(),
                  static_cast<long long>(s.quality.triangles), s.charts, s.lscm_charts, s.projection_charts,
                  s.single_charts, s.split_rounds, s.quality.utilisation, s.quality.l2_stretch,
                  s.quality.mean_angle_error_degrees, static_cast<long long>(s.quality.overlaps), s.seconds, per_100k);
    table += line;
    std::fputs(line, stdout);
    std::fflush(stdout);
  }
  std::printf("\nuvgen_bench: %zu meshes, packed into %d² with 4 texels of padding\n\n%s", meshes.size(), size,
              table.c_str());
  return bench::write_table_file(table, table_out);
}
