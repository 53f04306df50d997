#include "app/cmd_sensel_decode.h"

#include <fmt/format.h>

#include "capture/sensel_capture_file.h"
#include "capture/sensel_frame.h"
#include "capture/sensel_units.h"
#include "core/sequence_unwrap.h"

namespace pvcap {

Result<SenselDecodeSummary> decode_sensel_capture(const std::filesystem::path& path) {
  auto file = sensel::load_capture_file(path);
  if (!file) return file.error();
  auto grid = sensel::grid_from_metadata(file.value().metadata);
  if (!grid) return Error{fmt::format("{}: {}", path.string(), grid.error().message)};
  SenselDecodeSummary s;
  s.grid = grid.value();
  SequenceUnwrapper counter(8, /*zero_is_skipped=*/false);
  SequenceUnwrapper clock(32, false);  // µs timestamps wrap every ~71.6 min
  std::uint64_t first_us = 0, last_us = 0;
  auto reject = [&](const sensel::CapturedFrame& cf, const std::string& why) {
    ++s.rejected[why];
    if (s.first_rejection.empty()) s.first_rejection = fmt::format("frame at {}: {}", cf.line, why);
  };
  for (const auto& cf : file.value().frames) {
    ++s.frames;
    if (cf.checksum >= 0 && sensel::checksum(cf.payload) != cf.checksum) {
      reject(cf, "checksum mismatch");
      continue;
    }
    auto f = sensel::parse_frame(cf.payload, s.grid);
    if (!f) {
      reject(cf, f.error().message);
      continue;
    }
    ++s.decoded;
    s.counter_gaps += counter.next(f.value().counter).missing;
    const std::uint64_t t = clock.next(f.value().timestamp_us).sequence;
    if (s.decoded == 1) first_us = t;
    last_us = t;
    if (f.value().pressure) {
      double total = 0;
      for (std::uint16_t c : f.value().pressure->counts) {
        const double g = sensel::counts_to_grams(c);
        total += g;
        if (g > s.peak_cell_g) {
          s.peak_cell_g = g;
          s.peak_cell_kpa = sensel::native_cell_kpa(c, s.grid);
        }
      }
      s.peak_total_g = std::max(s.peak_total_g, total);
    }
  }
  s.span_s = double(last_us - first_us) / 1e6;
  return s;
}

int print_sensel_summary(const std::filesystem::path& path, const SenselDecodeSummary& s) {
  fmt::print("{}\n", path.string());
  fmt::print("  grid          {}x{} native, x{} y{} -> {}x{} sensels\n", s.grid.cols, s.grid.rows, s.grid.xscale,
             s.grid.yscale, s.grid.out_cols(), s.grid.out_rows());
  fmt::print("  frames        {} decoded of {}\n", s.decoded, s.frames);
  for (const auto& [why, n] : s.rejected) fmt::print("  rejected      {} x {}\n", n, why);
  fmt::print("  counter gaps  {} frames missing by the rolling counter\n", s.counter_gaps);
  fmt::print("  time span     {:.3f} s of device time{}\n", s.span_s,
             s.decoded > 1 ? fmt::format(" ({:.1f} frames/s)", double(s.decoded - 1) / std::max(s.span_s, 1e-9)) : "");
  fmt::print("  peak force    {:.1f} g on one {:.2f} x {:.2f} mm cell ({:.1f} kPa); {:.1f} g on the whole pad\n",
             s.peak_cell_g, 1.25 * s.grid.xscale, 1.25 * s.grid.yscale, s.peak_cell_kpa, s.peak_total_g);
  if (s.decoded != s.frames) {
    fmt::print("FAILED: {} frames could not be decoded (first: {})\n", s.frames - s.decoded, s.first_rejection);
    return 1;
  }
  return 0;
}

}  // namespace pvcap
