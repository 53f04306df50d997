// `pvcap sensel decode FILE`: prints what a Sensel wire dump (.json / .jsonl) holds
// (codec/sensel_capture_file.h decodes it); the process fails when any frame does.
#include "app/command.h"

#include <fmt/format.h>
#include "codec/sensel_capture_file.h"

namespace pvcap {

namespace {

int print_sensel_summary(const std::filesystem::path& path, const sensel::CaptureSummary& s) {
  fmt::print("{}\n", path.string());
  fmt::print("  grid          {}x{} native, x{} y{} -> {}x{} sensels\n", s.grid.cols, s.grid.rows, s.grid.xscale,
             s.grid.yscale, s.grid.out_cols(), s.grid.out_rows());
  fmt::print("  frames        {} decoded of {}\n", s.decoded, s.frames);
  for (const auto& [why, n] : s.rejected) fmt::print("  rejected      {} x {}\n", n, why);
  fmt::print("  counter gaps  {} frames missing by the rolling counter\n", s.counter_gaps);
  fmt::print("  time span     {:.3f} s of device time{}\n", s.span_s,
             s.decoded > 1 && s.span_s > 0
                 ? fmt::format(" ({:.1f} frames/s)", double(s.decoded - 1) / std::max(s.span_s, 1e-9))
                 : "");
  fmt::print("  peak force    {:.1f} g on one {:.2f} x {:.2f} mm cell ({:.1f} kPa); {:.1f} g on the whole pad\n",
             s.peak_cell_g, 1.25 * s.grid.xscale, 1.25 * s.grid.yscale, s.peak_cell_kpa, s.peak_total_g);
  if (s.decoded != s.frames) {
    fmt::print("FAILED: {} frames could not be decoded (first: {})\n", s.frames - s.decoded, s.first_rejection);
    return 1;
  }
  return 0;
}

}  // namespace

Registered add_sensel_command(CLI::App& app, AppContext&) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto* sensel = app.add_subcommand("sensel", "Sensel Morph tools");
  sensel->require_subcommand(1);
  auto* decode = sensel->add_subcommand("decode", "decode a Sensel wire dump (.json or .jsonl) and summarise it");
  decode->add_option("FILE", *files, "capture files")->required()->check(CLI::ExistingFile);
  return {sensel, [files] {
            int rc = 0;
            for (const auto& f : *files) {
              auto summary = sensel::summarise_capture_file(f);
              if (!summary) throw UserError(summary.error().message);
              rc = std::max(rc, print_sensel_summary(f, summary.value()));
            }
            return rc;
          }};
}

}  // namespace pvcap
