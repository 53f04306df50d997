// `pvcap camera check --node-map FILE.xml`: what pvcap would do with a camera, from its GenICam node
// map alone (no camera needed: before a lab records with it, or before it buys one).
#include <fstream>
#include <iterator>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "app/command.h"
#include "capture/genicam_node_map.h"
#include "core/rig_config.h"

namespace pvcap {

namespace {

std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw UserError(fmt::format("{}: cannot be read", path));
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

}  // namespace

Registered add_camera_command(CLI::App& app, AppContext&) {
  struct Args {
    std::string node_map, rig, camera, pixel_format;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  auto* camera = app.add_subcommand("camera", "check a camera against what pvcap needs");
  camera->require_subcommand(1);
  auto* check = camera->add_subcommand(
      "check",
      "from its GenICam node map alone (no camera needed): the feature pvcap would use for each role, "
      "the clock, PTP and chunk support, and what is missing. Exit 0 usable, 1 not, 2 not a node map");
  check->add_option("--node-map", a->node_map, "the camera's GenICam XML")->required()->check(CLI::ExistingFile);
  auto* rig =
      check->add_option("--rig", a->rig, "a rig file: check against its camera's section")->check(CLI::ExistingFile);
  check->add_option("--camera", a->camera, "the camera's name in the rig file (default: its first)")->needs(rig);
  check->add_option("--pixel-format", a->pixel_format,
                    "the pixel format to record in (default BayerRG8, or the rig's; this wins over the rig's)");
  check->add_flag("--json", a->json, "one JSON object: usable, clock, features, missing, ...");
  return {camera, [a] {
            CameraConfig camera;  // the defaults: BayerRG8, free-running
            if (!a->rig.empty()) {
              const RigConfig rig = load_rig_config(a->rig);
              const CameraConfig* chosen = rig.cameras.empty() ? nullptr : &rig.cameras.front();
              for (const auto& c : rig.cameras)
                if (c.name == a->camera) chosen = &c;
              if (!chosen || (!a->camera.empty() && chosen->name != a->camera))
                throw UserError(fmt::format("{}: no camera named '{}'", a->rig, a->camera));
              camera = *chosen;
            }
            if (!a->pixel_format.empty()) camera.pixel_format = a->pixel_format;
            auto map = GenicamNodeMap::parse(read_file(a->node_map));
            if (!map) {
              fmt::print(stderr, "pvcap: {}: {}\n", a->node_map, map.error().message);
              return 2;
            }
            const NodeMapCheck c = check_node_map(map.value(), camera);
            if (a->json)
              fmt::print("{}\n", node_map_check_json(c).dump(2));
            else
              fmt::print("{}", describe_node_map_check(c, a->node_map));
            return c.usable() ? 0 : 1;
          }};
}

}  // namespace pvcap
