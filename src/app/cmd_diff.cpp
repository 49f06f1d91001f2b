// penumbra diff A B [--on v|color] [--heatmap OUT.png] [--signed] [--json]
// Error of image A against image B (the reference): MAE, RMSE, PSNR, max, and FLIP on
// colour images.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/command.h"
#include "app/common.h"
#include "penumbra/core/image.h"
#include "penumbra/eval/flip.h"
#include "penumbra/eval/heatmap.h"
#include "penumbra/eval/metrics.h"

namespace penumbra::app {
namespace {

struct DiffOptions {
  std::string a, b, on = "auto", heatmap;
  bool signed_map = false, json = false;
};

bool is_exr(const std::string& p) {
  std::string ext = std::filesystem::path(p).extension().string();
  return ext == ".exr" || ext == ".EXR";
}

bool exr_has_v(const std::string& p) {
  if (!is_exr(p)) return false;
  try {
    read_exr_channel(p, "V");
    return true;
  } catch (const Error&) {
    return false;
  }
}

int run_diff(const DiffOptions& o) {
  std::string on = o.on;
  if (on == "auto") on = (exr_has_v(o.a) && exr_has_v(o.b)) ? "v" : "color";
  if (!o.heatmap.empty()) check_output_path(o.heatmap, {".png", ".exr"});
  Image a, b;
  if (on == "v") {
    // V from an EXR's V channel, or a one-channel image (--visibility-out PNG: linear).
    auto load_v = [](const std::string& p) {
      if (is_exr(p)) return read_exr_channel(p, "V");
      Image img = read_image(p, /*linear_png=*/true);
      if (img.channels() != 1) throw Error("{}: --on v needs an EXR with a V channel or a grey image", p);
      return img;
    };
    a = load_v(o.a);
    b = load_v(o.b);
  } else {
    a = read_image(o.a);
    b = read_image(o.b);
  }
  ErrorStats st = compare_images(a, b);
  nlohmann::json j = {{"test", o.a}, {"reference", o.b}, {"on", on}, {"mae", st.mae}, {"rmse", st.rmse},
                      {"max_abs", st.max_abs}, {"mean_signed", st.mean_signed},
                      {"psnr", std::isfinite(st.psnr) ? nlohmann::json(st.psnr) : nlohmann::json("inf")},
                      {"pixels", st.pixels}};
  if (on == "color") j["flip"] = flip(a, b).mean;
  if (!o.heatmap.empty()) {
    Image d = difference_map(a, b, on == "v" ? ChannelSelect::all() : ChannelSelect::luminance());
    Heatmap h;
    if (o.signed_map) {
      h = signed_heatmap(d);
    } else {
      for (float& x : d.data()) x = std::abs(x);
      h = absolute_heatmap(d);
    }
    write_image(o.heatmap, h.image, {}, /*linear_png=*/false);
    j["heatmap"] = {{"file", o.heatmap}, {"legend", h.legend()}};
  }
  if (o.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("%s vs %s (%s): MAE %.6f  RMSE %.6f  PSNR %s dB  max %.6f  mean signed %+.6f", o.a.c_str(), o.b.c_str(),
                on.c_str(), st.mae, st.rmse, std::isfinite(st.psnr) ? fmt::format("{:.2f}", st.psnr).c_str() : "inf",
                st.max_abs, st.mean_signed);
    if (j.contains("flip")) std::printf("  FLIP %.6f", j["flip"].get<double>());
    std::printf("\n");
  }
  return 0;
}

const CommandRegistration diff_command("diff", 40, [](CLI::App& app) {
  auto o = std::make_shared<DiffOptions>();
  CLI::App* cmd = app.add_subcommand("diff", "error of image A against reference B (MAE, RMSE, PSNR, max, FLIP)");
  cmd->add_option("a", o->a, "test image (.exr, .png)")->required();
  cmd->add_option("b", o->b, "reference image (.exr, .png)")->required();
  cmd->add_option("--on", o->on, "compare V (the EXR's V channel) or colour; auto: V when both have it")
      ->check(CLI::IsMember({"auto", "v", "color"}))->capture_default_str();
  cmd->add_option("--heatmap", o->heatmap, "write an error heatmap (.png)");
  cmd->add_flag("--signed", o->signed_map, "signed (blue-white-red) heatmap instead of absolute");
  cmd->add_flag("--json", o->json, "print the metrics as JSON");
  return [o] { return run_diff(*o); };
});

}  // namespace
}  // namespace penumbra::app
