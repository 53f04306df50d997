// `pvcap devices`: the GigE Vision cameras that answer discovery and the Sensel Morphs on a tty or
// the USB bus (read without resetting them), as a table or one JSON object per line; or one camera's
// node map, written to a file (`--dump-node-map`). With `--sim`, a simulated rig is started first.
#include "app/command.h"
#include "app/rig_launcher.h"

#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>

#include <functional>
#include "capture/device_listing.h"
#include "core/durable_folder.h"
#include "sim/sim_rig.h"

namespace pvcap {

namespace {

int cmd_devices(bool json, const std::vector<std::string>& extra_ttys) {
  const auto cams = discover_gige_cameras();
  const auto listing = sensel::list_sensels(extra_ttys);
  for (const auto& note : listing.notes) fmt::print(stderr, "{}\n", note);
  const auto& sensels = listing.found;
  fmt::print("{}", device_listing(cams, sensels, json));
  return 0;
}

int dump_node_map(const std::string& camera, const std::string& out) {
  auto xml = read_node_map(camera);
  if (!xml) throw UserError(xml.error().message);
  if (Status s = write_file_atomically(out, xml.value(), Durability::Synced); !s.ok())
    throw UserError(s.error().message);
  fmt::print("wrote {}: camera {}'s node map ({} bytes); check it with `pvcap camera check --node-map {}`\n", out,
             camera, xml.value().size(), out);
  return 0;
}

int cmd_devices_of_sim(bool json, const RigConfig& rig, const std::function<int()>& with_devices) {
  const auto tmp = std::filesystem::temp_directory_path() / fmt::format("pvcap-devices-{}", getpid());
  // The simulator's folder goes whatever happens (a camera not found for --dump-node-map throws),
  // after the simulator (declared first, destroyed last).
  struct RemoveAfter {
    std::filesystem::path dir;
    ~RemoveAfter() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  } remove_after{tmp};
  auto made = sim::SimRig::create(rig, tmp);
  if (!made) throw UserError(made.error().message);
  std::vector<std::string> extra;
  if (std::filesystem::exists(tmp / "sensel.tty")) extra.push_back((tmp / "sensel.tty").string());
  const int rc = with_devices ? with_devices() : cmd_devices(json, extra);
  made.value().reset();
  return rc;
}

}  // namespace

Registered add_devices_command(CLI::App& app, AppContext&) {
  struct Args {
    bool json = false;
    std::string sim;
    std::vector<std::string> ttys;
    std::string dump_camera, dump_out;
  };
  auto a = std::make_shared<Args>();
  auto* d = app.add_subcommand("devices", "list the cameras (and sensors) this machine can reach");
  d->add_flag("--json", a->json, "one JSON object per device");
  d->add_option("--tty", a->ttys, "also ask the Sensel on these serial ports (e.g. /dev/serial/by-id/...)");
  d->add_option("--sim", a->sim, "first start this simulated rig (a rig file with a sim: section)")
      ->check(CLI::ExistingFile);
  auto* dump = d->add_option("--dump-node-map", a->dump_camera,
                             "write this camera's GenICam XML (by serial or address) instead of the listing");
  d->add_option("--out", a->dump_out, "where --dump-node-map writes (default: <camera>.xml)")->needs(dump);
  return {d, [a] {
            std::function<int()> dumping;
            if (!a->dump_camera.empty())
              dumping = [a] {
                return dump_node_map(a->dump_camera, a->dump_out.empty() ? a->dump_camera + ".xml" : a->dump_out);
              };
            if (a->sim.empty()) return dumping ? dumping() : cmd_devices(a->json, a->ttys);
            const auto rig = load_rig_config(a->sim);
            if (!rig.simulated) throw UserError(fmt::format("{}: has no sim: section", a->sim));
            run_under_rig_preload(rig);
            prepare_rig_network(rig);
            return cmd_devices_of_sim(a->json, rig, dumping);
          }};
}

}  // namespace pvcap
