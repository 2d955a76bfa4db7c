#include "bakers/material/table_images.h"

#include "bakers/image/exr.h"
#include "bakers/material/number_text.h"

namespace kiln::material {

std::string table_settings(const MaterialBakeInput& input) {
  return "table_mu=" + std::to_string(input.table_mu) + " table_roughness=" + std::to_string(input.table_roughness) +
         " samples=" + std::to_string(input.samples) + " target_error=" + shortest_number(input.target_error) +
         " seed=" + std::to_string(input.seed);
}

bake::BakeOutput albedo_image(const MaterialBakeResult& result, const std::string& settings) {
  const int n_mu = static_cast<int>(result.albedo.e.size());
  image::FloatImage img;
  img.width = n_mu;
  img.height = 1;
  img.channels = 8;
  img.channel_names = {"R", "G", "B", "err.R", "err.G", "err.B", "white", "white_err"};
  img.pixels.resize(static_cast<size_t>(n_mu) * 8);
  for (int i = 0; i < n_mu; ++i) {
    const brdf::Estimate& a = result.albedo.e[i];
    const brdf::Estimate& w = result.white_furnace.e[i];
    const double px[8] = {a.value.r,     a.value.g,     a.value.b,         a.std_error.r,
                          a.std_error.g, a.std_error.b, w.value.average(), w.std_error.max()};
    for (int c = 0; c < 8; ++c) img.at(i, 0, c) = static_cast<float>(px[c]);
  }
  img.metadata["kiln:table"] = "directional albedo E(mu) = integral of f cos(theta_i) over the hemisphere";
  img.metadata["kiln:x_axis"] = "mu = cos(theta_o) = (x + 0.5) / " + std::to_string(n_mu);
  for (const char* c : {"R", "G", "B"}) {
    img.metadata[std::string("kiln:channel.") + c] = std::string("E(mu) of the model as configured, channel ") + c;
    img.metadata[std::string("kiln:channel.err.") + c] = std::string("standard error of ") + c;
  }
  img.metadata["kiln:channel.white"] = "E(mu) of the white, Fresnel-free form (the white furnace)";
  img.metadata["kiln:channel.white_err"] = "standard error of white";
  img.metadata["kiln:model"] = result.description;
  img.metadata["kiln:average_albedo"] = rgb_list(result.average_albedo);
  img.metadata["kiln:settings"] = settings;
  return {"albedo.exr", "image/x-exr", "scene_linear", image::encode_exr(img)};
}

bake::BakeOutput split_sum_image(const MaterialBakeResult& result, brdf::Model model, bool rough_axis,
                                 const std::string& settings) {
  const brdf::SplitSumTable& t = result.split_sum;
  const int n_mu = t.n_mu, n_r = t.n_roughness;
  image::FloatImage img;
  img.width = n_mu;
  img.height = n_r;
  img.channels = 4;
  img.channel_names = {"scale", "bias", "scale_err", "bias_err"};
  img.pixels.resize(static_cast<size_t>(n_mu) * n_r * 4);
  for (int j = 0; j < n_r; ++j) {
    for (int i = 0; i < n_mu; ++i) {
      const size_t idx = static_cast<size_t>(j) * n_mu + i;
      img.at(i, j, 0) = static_cast<float>(t.scale[idx]);
      img.at(i, j, 1) = static_cast<float>(t.bias[idx]);
      img.at(i, j, 2) = static_cast<float>(t.scale_error[idx]);
      img.at(i, j, 3) = static_cast<float>(t.bias_error[idx]);
    }
  }
  img.metadata["kiln:table"] = "split sum: E ~= f0 * scale + bias, white model without Fresnel";
  img.metadata["kiln:channel.scale"] = "scale: the factor on f0";
  img.metadata["kiln:channel.bias"] = "bias: the term added";
  img.metadata["kiln:channel.scale_err"] = "standard error of scale";
  img.metadata["kiln:channel.bias_err"] = "standard error of bias";
  img.metadata["kiln:x_axis"] = "mu = cos(theta_o) = (x + 0.5) / " + std::to_string(n_mu);
  img.metadata["kiln:y_axis"] = std::string(brdf::roughness_name(model)) + " = (y + 0.5) / " + std::to_string(n_r) +
                                " * " + shortest_number(brdf::max_roughness(model)) +
                                (rough_axis ? "" : " (no roughness parameter: every row is the same)");
  img.metadata["kiln:model"] = "white, Fresnel-free form of " + result.description;
  img.metadata["kiln:settings"] = settings;
  return {"split_sum.exr", "image/x-exr", "data", image::encode_exr(img)};
}

}  // namespace kiln::material
