// Writes the seed corpora of the fuzz targets (tests/fuzz/corpus/NAME/): small valid inputs made with kiln's own
// encoders, so the fuzzers start from the formats as kiln writes and reads them. The files are committed; run this
// again (tests/fuzz/run.sh --seeds) when a format changes.
//   usage: fuzz_make_seeds CORPUS_DIR EXAMPLES_DIR
#include <google/protobuf/text_format.h>

#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "bakers/image/exr.h"
#include "bakers/image/ktx2.h"
#include "bakers/image/png.h"
#include "bakers/volume/vdb_file.h"
#include "bakers/volume/vdb_grid.h"
#include "client/import/mesh_blob.h"
#include "proto/digest.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"

namespace fs = std::filesystem;
using namespace kiln;

namespace {

fs::path g_corpus;

void write(const std::string& target, const std::string& name, const std::string& bytes) {
  const fs::path dir = g_corpus / target;
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary) << bytes;
}

std::string read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A small image in any format OpenImageIO writes, through a temporary file (some plugins cannot write to memory).
std::string oiio_image(const std::string& extension, int width, int height, int channels, bool floats) {
  const fs::path path = fs::temp_directory_path() / ("kiln-fuzz-seed" + extension);
  std::vector<float> pixels(static_cast<size_t>(width) * height * channels);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<float>(i % 7) / 6.0f * (floats ? 4.0f : 1.0f);
  auto out = OIIO::ImageOutput::create(path.string());
  if (!out) throw std::runtime_error("no writer for " + extension);
  const OIIO::ImageSpec spec(width, height, channels, floats ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
  if (!out->open(path.string(), spec) || !out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()) || !out->close()) {
    throw std::runtime_error("cannot write " + path.string() + ": " + out->geterror());
  }
  std::string bytes = read(path);
  fs::remove(path);
  return bytes;
}

image::FloatImage float_image(int width, int height, int channels) {
  image::FloatImage im;
  im.width = width;
  im.height = height;
  im.channels = channels;
  for (int i = 0; i < width * height * channels; ++i) im.pixels.push_back(static_cast<float>(i) * 0.25f);
  return im;
}

client::MeshArrays triangle(bool everything) {
  client::MeshArrays m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  m.indices = {0, 1, 2, 2, 1, 3};
  if (everything) {
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    m.uv = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
    m.lightmap_uv = m.uv;
    m.materials = {0, 1};
  }
  return m;
}

const char* const kLightmapJob = R"pb(
name: "fuzz seed"
quality { samples: 16 }
force_effects { key: "specular_interreflection" value: false }
lightmap {
  meshes { name: "floor" geometry { sha256: "0000000000000000000000000000000000000000000000000000000000000000" size: 188 } }
  instances { mesh: 0 transform: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 2] lightmap: "atlas" lightmap_scale_offset: [0.5, 0.5, 0, 0] }
  instances { mesh: 0 bake: false }
  textures { name: "t.png" image { sha256: "1111111111111111111111111111111111111111111111111111111111111111" size: 70 } color_space: "srgb_texture" }
  materials { name: "white" base_color { r: 0.7 g: 0.6 b: 0.5 } base_color_texture: 0 two_sided: true
              bsdf { diffuse { oren_nayar { sigma: 0.3 } } specular { ggx { alpha: 0.2 } } } }
  materials { name: "lamp" emission { r: 5 g: 5 b: 5 } }
  material_overrides { name: "white" base_color { r: 0.2 g: 0.2 b: 0.2 } }
  lights { name: "bulb" color { r: 10 g: 10 b: 10 } point { position { x: 0 y: 1 z: 0 } } }
  lights { name: "spot" color { r: 1 g: 1 b: 1 } spot { position { y: 2 } direction { y: -1 } inner_cone_angle: 0.2 outer_cone_angle: 0.5 } }
  lights { name: "sun" color { r: 3 g: 3 b: 3 } directional { direction { x: 1 y: -1 } angular_diameter: 0.01 } }
  lights { name: "panel" color { r: 1 g: 1 b: 1 } rect { center { y: 2 } u { x: 1 } v { z: 1 } two_sided: true } }
  lights { name: "disk" color { r: 1 g: 1 b: 1 } disk { center { y: 2 } normal { y: -1 } radius: 0.5 } }
  environment { constant { r: 0.1 g: 0.2 b: 0.3 } intensity: 2 }
  resolution: 32
  lightmaps { name: "atlas" resolution: 64 }
  padding: 2
  max_bounces: 3
  radiance: true
  ao: true
  directional: true
  preview: false
  denoise: true
  error_metric: LIGHTMAP_ERROR_METRIC_TEXEL
}
)pb";

const char* const kEnvironmentImageJob = R"pb(
name: "sky"
environment {
  image { sha256: "2222222222222222222222222222222222222222222222222222222222222222" size: 4096 }
  color_space: "lin_rec709" rotation_degrees: 90 intensity: 2 size: 16 levels: 2 irradiance_size: 4
  dfg_size: 8 dfg_samples: 16 preview: false
}
)pb";

std::vector<std::pair<std::string, v1::JobSpec>> job_specs(const fs::path& examples) {
  std::vector<std::pair<std::string, v1::JobSpec>> specs;
  for (const auto& entry : fs::directory_iterator(examples)) {
    if (entry.path().extension() != ".textproto") continue;
    v1::JobSpec spec;
    if (!google::protobuf::TextFormat::ParseFromString(read(entry.path()), &spec)) {
      throw std::runtime_error("cannot parse " + entry.path().string());
    }
    specs.emplace_back(entry.path().stem().string(), spec);
  }
  for (const auto& [name, text] : {std::pair{"lightmap", kLightmapJob}, {"environment_image", kEnvironmentImageJob}}) {
    v1::JobSpec spec;
    if (!google::protobuf::TextFormat::ParseFromString(text, &spec)) throw std::runtime_error("bad seed " + std::string(name));
    specs.emplace_back(name, spec);
  }
  return specs;
}

// A client's first bytes on a connection: Hello, then `then`; `read_size` is request_fuzz's first byte.
std::string stream(char read_size, const std::vector<v1::Request>& requests) {
  std::string bytes(1, read_size);
  for (const v1::Request& r : requests) proto::append_frame(r, bytes);
  return bytes;
}

// A glTF 2.0 triangle with its buffer in a data URI (no external files), or for a GLB (`bin` not null) in `*bin`.
std::string gltf_triangle(std::string* bin_out = nullptr) {
  // 3 positions (36 bytes) then 3 uint16 indices (6 bytes), base64-encoded by hand below.
  std::string bin(42, '\0');
  const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::memcpy(bin.data(), p, 36);
  const uint16_t idx[3] = {0, 1, 2};
  std::memcpy(bin.data() + 36, idx, 6);
  if (bin_out) *bin_out = bin;
  static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string enc;
  for (size_t i = 0; i < bin.size(); i += 3) {
    const uint32_t n = (uint8_t(bin[i]) << 16) | (i + 1 < bin.size() ? uint8_t(bin[i + 1]) << 8 : 0) |
                       (i + 2 < bin.size() ? uint8_t(bin[i + 2]) : 0);
    enc += b64[(n >> 18) & 63];
    enc += b64[(n >> 12) & 63];
    enc += i + 1 < bin.size() ? b64[(n >> 6) & 63] : '=';
    enc += i + 2 < bin.size() ? b64[n & 63] : '=';
  }
  return std::string(R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0,"name":"n"}],)"
         R"("meshes":[{"name":"tri","primitives":[{"attributes":{"POSITION":0},"indices":1,"material":0}]}],)"
         R"("materials":[{"name":"m","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.5,0.2,1],"metallicFactor":0,)"
         R"("roughnessFactor":0.5}}],)"
         R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},)"
         R"({"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}],)"
         R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],)") +
         (bin_out ? std::string(R"("buffers":[{"byteLength":42}]})")
                  : R"("buffers":[{"byteLength":42,"uri":"data:application/octet-stream;base64,)" + enc + R"("}]})");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR EXAMPLES_DIR\n", argv[0]);
    return 2;
  }
  g_corpus = argv[1];
  const fs::path examples = argv[2];
  try {
    const auto specs = job_specs(examples);

    // Daemon: job specs, and whole streams of frames.
    int id = 1;
    v1::Request hello;
    hello.set_id(id++);
    hello.mutable_hello()->set_protocol_version(proto::kProtocolVersion);
    hello.mutable_hello()->set_token("secret");
    hello.mutable_hello()->set_client("fuzz");
    for (const auto& [name, spec] : specs) {
      write("job_spec", name + ".pb", spec.SerializeAsString());
      v1::Request submit;
      submit.set_id(id++);
      *submit.mutable_submit()->mutable_job() = spec;
      submit.mutable_submit()->set_priority(1);
      submit.mutable_submit()->set_idempotency_key("key-" + name);
      write("request", "submit_" + name + ".bin", stream(char(255), {hello, submit}));
    }
    v1::Request query, put, watch, fetch, list;
    query.set_id(id++);
    auto* d = query.mutable_blob_query()->add_digests();
    d->set_sha256(proto::sha256_hex("abc"));
    d->set_size(3);
    put.set_id(id++);
    *put.mutable_blob_put()->mutable_digest() = *d;
    put.mutable_blob_put()->set_data("abc");
    watch.set_id(id++);
    watch.mutable_watch()->set_job_id("j1");
    fetch.set_id(id++);
    *fetch.mutable_fetch()->mutable_digest() = *d;
    fetch.mutable_fetch()->set_length(2);
    list.set_id(id++);
    list.mutable_list_jobs();
    write("request", "blobs.bin", stream(char(0), {hello, query, put}));
    write("request", "jobs.bin", stream(char(7), {hello, watch, fetch, list}));

    // Mesh blobs.
    write("mesh_blob", "quad_all_arrays.bin", client::encode_mesh_blob(triangle(true)));
    write("mesh_blob", "quad_positions.bin", client::encode_mesh_blob(triangle(false)));

    // Images.
    image::FloatImage rgb = float_image(4, 2, 3);
    rgb.metadata["comment"] = "fuzz seed";
    const std::string exr = image::encode_exr(rgb);
    write("exr", "rgb_4x2.exr", exr);
    image::FloatImage rgba = float_image(2, 2, 4);
    rgba.channel_names = {"R", "G", "B", "A"};
    write("exr", "rgba_2x2.exr", image::encode_exr(rgba));
    image::Png8Image png;
    png.width = 4;
    png.height = 2;
    png.channels = 3;
    png.pixels.assign(24, 128);
    png.metadata["Description"] = "fuzz seed";
    const std::string png_rgb = image::encode_png(png);
    write("png", "rgb_4x2.png", png_rgb);
    png.channels = 1;
    png.pixels.assign(8, 200);
    png.metadata.clear();
    write("png", "grey_4x2.png", image::encode_png(png));
    const std::string jpeg = oiio_image(".jpg", 4, 2, 3, false);
    const std::string hdr = oiio_image(".hdr", 4, 2, 3, true);
    write("texture", "rgb_4x2.png", png_rgb);
    write("texture", "rgb_4x2.exr", exr);
    write("texture", "rgb_4x2.jpg", jpeg);
    write("texture", "rgb_4x2.hdr", hdr);
    write("texture", "rgb_4x2.tga", oiio_image(".tga", 4, 2, 3, false));
    write("environment", "rgb_4x2.exr", exr);
    write("environment", "rgb_4x2.hdr", hdr);
    write("environment", "rgb_4x2.png", png_rgb);
    write("environment", "rgb_4x2.jpg", jpeg);

    // KTX2: a 2-D image with two levels in half floats, a cube map in floats.
    image::Ktx2Image flat;
    flat.width = 4;
    flat.height = 2;
    flat.levels = 2;
    flat.data = {std::vector<float>(4 * 2 * 4, 0.5f), std::vector<float>(2 * 1 * 4, 1.5f)};
    flat.key_values["KTXorientation"] = "rd";
    write("ktx2", "rgba16f_4x2_2levels.ktx2", image::encode_ktx2(flat));
    image::Ktx2Image cube;
    cube.width = cube.height = 2;
    cube.faces = 6;
    cube.format = image::Ktx2Image::rgba32f;
    cube.data.assign(6, std::vector<float>(2 * 2 * 4, 0.25f));
    write("ktx2", "rgba32f_cube_2.ktx2", image::encode_ktx2(cube));

    // OpenVDB files (read_vdb): a density grid of a few voxels, and one with an emission grid beside it.
    auto vdb = [](const std::vector<volume::VdbGrid>& grids) {
      const std::vector<uint8_t> bytes = volume::write_vdb(grids);
      return std::string(bytes.begin(), bytes.end());
    };
    const volume::VdbGrid density = volume::make_vdb_grid("density", 2, 2, 2, {0.5f, 1, 0, 2, 0.25f, 0, 3, 1}, 0.1);
    write("vdb", "density_2x2x2.vdb", vdb({density}));
    write("vdb", "density_and_emission.vdb",
          vdb({density, volume::make_vdb_grid("emission", 3, 1, 1, {1, 2, 4}, 0.05, {0.5, 0, 0}, {-1, 4, 7})}));

    // Job files: the examples, and every spec above as text.
    for (const auto& [name, spec] : specs) {
      std::string text;
      google::protobuf::TextFormat::PrintToString(spec, &text);
      write("job_text", name + ".textproto", text);
    }
    write("job_text", "field_path.textproto",
          std::string("material { ggx { alpha: 0.3 } }\n") + '\0' + "job.material.ggx.alpha");

    // Scene import: the first byte picks the extension (0 .gltf, 1 .glb, 2 .obj, 3 .fbx).
    const std::string gltf = gltf_triangle();
    write("scene_import", "triangle.gltf", std::string(1, '\0') + gltf);
    std::string bin;
    std::string json = gltf_triangle(&bin);
    while (json.size() % 4) json += ' ';
    while (bin.size() % 4) bin += '\0';
    auto u32 = [](size_t v) {
      const auto n = static_cast<uint32_t>(v);
      return std::string(reinterpret_cast<const char*>(&n), 4);
    };
    const std::string glb = "glTF" + u32(2) + u32(12 + 8 + json.size() + 8 + bin.size()) + u32(json.size()) +
                            "JSON" + json + u32(bin.size()) + std::string("BIN\0", 4) + bin;
    write("scene_import", "triangle.glb", std::string(1, '\1') + glb);
    write("scene_import", "quad.obj",
          std::string(1, '\2') +
              "o quad\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvn 0 0 1\n"
              "usemtl none\nf 1/1/1 2/2/1 3/3/1\nf 3/3/1 2/2/1 4/4/1\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_make_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
