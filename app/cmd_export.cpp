// `pvcap export SESSION... --layout pressurevision|pressurevision-plus --out DIR [options]`: each
// session written in a released dataset layout (export/dataset_export.h), one after the other, with
// progress and the time left; an interrupted export resumes when run again.
#include "app/command.h"

#include "console/progress_line.h"

#include <chrono>
#include <cstdio>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include "export/dataset_export.h"

namespace pvcap {

namespace {
struct ExportCommand {
  std::vector<std::filesystem::path> sessions;
  exporting::ExportOptions options;
};
}  // namespace

namespace {

int cmd_export(const ExportCommand& c, const std::atomic<bool>& stop) {
  int rc = 0;
  for (const auto& session : c.sessions) {
    exporting::ExportOptions o = c.options;
    const auto started = std::chrono::steady_clock::now();
    console::ProgressLine bar;
    o.progress = [&](std::size_t done, std::size_t total) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      const double rate = s > 0 ? double(done) / s : 0;
      const double left = rate > 0 ? double(total - done) / rate : 0;
      bar.show(fmt::format("{}: {}/{} frames, {:.1f} frames/s, {:.0f} s left", session.filename().string(), done, total,
                           rate, left),
               done, total);
    };
    auto r = exporting::export_session(session, o, stop);
    if (!r) {
      spdlog::error("{}", r.error().message);
      rc = 1;
      continue;
    }
    const auto& e = r.value();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    fmt::print("{} -> {}\n", session.string(), e.participant_folder.string());
    for (const auto& cam : e.cameras)
      fmt::print(
          "  camera {}: the loaders' pad corners lie {:.2f} px RMS ({:.2f} px at most) from the measured ones "
          "(their 235 x 135 mm pad against the real 231.25 x 131.25 mm grid)\n",
          cam.name, cam.loader_corner_rms_px, cam.loader_corner_max_px);
    std::size_t frames = 0, left_out = 0;
    for (const auto& q : e.sequences) {
      frames += q.frames;
      left_out += q.samples_left_out;
      fmt::print("  {:<48} {:>5} frames{}{}\n", q.folder, q.frames, q.status == "done" ? "" : " (" + q.status + ")",
                 q.was_complete ? ", already exported" : "");
    }
    fmt::print(
        "  {} sequences, {} frames ({} written now, {} found from an earlier run) in {:.1f} s{}\n", e.sequences.size(),
        frames, e.frames_written, e.frames_found, s,
        left_out ? fmt::format("; {} samples left out (a camera's frame or the pressure missing)", left_out) : "");
    if (e.interrupted) {
      fmt::print("  interrupted: run the same command again to finish (whole files are kept)\n");
      return 130;
    }
  }
  return rc;
}

}  // namespace

Registered add_export_command(CLI::App& app, AppContext& ctx) {
  struct Args {
    ExportCommand c;
    std::string layout = "pressurevision", force_format = "pkl", take;
    std::vector<std::size_t> cameras;
    double from = -1, to = -1;
  };
  auto a = std::make_shared<Args>();
  auto* e = app.add_subcommand("export",
                               "write sessions in the PressureVisionDB layout (the released loaders read "
                               "them unchanged); one independent job per session");
  e->add_option("SESSION", a->c.sessions, "session folders")->required()->check(CLI::ExistingDirectory);
  e->add_option("--layout", a->layout,
                "pressurevision (metadata.json) or pressurevision-plus (meta.json, a "
                "homography per frame)")
      ->check(CLI::IsMember({"pressurevision", "pressurevision-plus"}));
  e->add_option("--out", a->c.options.out, "the dataset folder (shared by many sessions)")->required();
  e->add_option("--take", a->take, "only this take (its sequence name, as `pvcap takes` lists it)");
  e->add_option("--from", a->from, "only samples from this many seconds after the session's start");
  e->add_option("--to", a->to, "only samples before this many seconds after the session's start");
  e->add_option("--cameras", a->cameras, "only these cameras (0-based indices, e.g. --cameras 0 2)");
  e->add_option("--jpeg-quality", a->c.options.jpeg_quality, "JPEG quality, 1..100 (default 95)")
      ->check(CLI::Range(1, 100));
  e->add_option("--force-format", a->force_format, "pkl (what the loaders read, default) or npy")
      ->check(CLI::IsMember({"pkl", "npy"}));
  e->add_flag("--crop-paper", a->c.options.paper_crop,
              "the paper's crop: each frame cut to the pad + 50 px, 480 x 384 (intrinsics adjusted)");
  e->add_flag("--include-all", a->c.options.include_all,
              "also superseded, bad and interrupted takes (done takes only by default)");
  return {e, [a, &ctx] {
            auto& o = a->c.options;
            o.layout = a->layout == "pressurevision" ? exporting::Layout::PressureVision
                                                     : exporting::Layout::PressureVisionPlus;
            o.npy = a->force_format == "npy";
            o.cameras = a->cameras;
            if (!a->take.empty()) o.take = a->take;
            if (a->from >= 0) o.from_s = a->from;
            if (a->to >= 0) o.to_s = a->to;
            return cmd_export(a->c, ctx.stop);
          }};
}

}  // namespace pvcap
