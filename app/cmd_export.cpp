#include "app/cmd_export.h"

#include "app/progress_line.h"


#include <chrono>
#include <cstdio>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pvcap {

int cmd_export(const ExportCommand& c, const std::atomic<bool>& stop) {
  int rc = 0;
  for (const auto& session : c.sessions) {
    exporting::ExportOptions o = c.options;
    const auto started = std::chrono::steady_clock::now();
    ProgressLine bar;
    o.progress = [&](std::size_t done, std::size_t total) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      const double rate = s > 0 ? double(done) / s : 0;
      const double left = rate > 0 ? double(total - done) / rate : 0;
      bar.show(fmt::format("{}: {}/{} frames, {:.1f} frames/s, {:.0f} s left", session.filename().string(), done,
                           total, rate, left),
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
      fmt::print("  camera {}: the loaders' pad corners lie {:.2f} px RMS ({:.2f} px at most) from the measured ones "
                 "(their 235 x 135 mm pad against the real 231.25 x 131.25 mm grid)\n",
                 cam.name, cam.loader_corner_rms_px, cam.loader_corner_max_px);
    std::size_t frames = 0, left_out = 0;
    for (const auto& q : e.sequences) {
      frames += q.frames;
      left_out += q.samples_left_out;
      fmt::print("  {:<48} {:>5} frames{}{}\n", q.folder, q.frames, q.status == "done" ? "" : " (" + q.status + ")",
                 q.was_complete ? ", already exported" : "");
    }
    fmt::print("  {} sequences, {} frames ({} written now, {} found from an earlier run) in {:.1f} s{}\n",
               e.sequences.size(), frames, e.frames_written, e.frames_found, s,
               left_out ? fmt::format("; {} samples left out (a camera's frame or the pressure missing)", left_out)
                        : "");
    if (e.interrupted) {
      fmt::print("  interrupted: run the same command again to finish (whole files are kept)\n");
      return 130;
    }
  }
  return rc;
}

}  // namespace pvcap
