#include "report/session_text.h"

#include <fmt/format.h>

#include "protocol/takes.h"
#include "storage/index/session_reader.h"

namespace pvcap::report {

namespace {
bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }
}  // namespace

Result<std::string> session_text(const std::filesystem::path& dir, std::optional<double> recorded_s) {
  auto opened = SessionReader::open(dir);
  if (!opened) return opened.error();
  SessionReader& r = *opened.value();
  auto streams = r.stream_statistics();
  if (!streams) return streams.error();
  auto counts = r.timeline_counts();
  if (!counts) return counts.error();
  auto count_of = [&](const std::string& what) -> std::uint64_t {
    for (const auto& [w, n] : counts.value())
      if (w == what) return n;
    return 0;
  };
  const SessionInfo& info = r.info();
  if (!recorded_s && info.ended_host_ns) recorded_s = double(*info.ended_host_ns - info.started_host_ns) / 1e9;

  fmt::memory_buffer buf;
  auto out = std::back_inserter(buf);
  fmt::format_to(out, "session: {}\n", dir.string());
  fmt::format_to(out, "ended: {} after {:.1f} s\n", info.end_reason.empty() ? "(did not end cleanly)" : info.end_reason,
                 recorded_s.value_or(0.0));
  fmt::format_to(out, "{:<8} {:>9} {:>9} {:>9} {:>11} {:>12} {:>12} {:>11} {:>9}\n", "camera", "received", "good",
                 "in video", "incomplete", "not received", "pvcap behind", "enc. behind", "lost conn");
  bool any_loss = false;
  std::string notes;
  for (const auto& s : streams.value()) {
    if (s.kind == "camera") {
      // Buffers without their own identity are recorded, not counted: the frames they were are
      // in the drops (not received).
      std::uint64_t unidentified = 0, duplicates = 0, foreign = 0;
      for (const auto& [why, n] : s.not_kept) {
        if (starts_with(why, "no_frame_id_") || starts_with(why, "stale_metadata_")) unidentified += n;
        if (why == "duplicate_frame_id") duplicates += n;
        if (starts_with(why, "foreign_frame_")) foreign += n;  // another camera's: not this one's at all
      }
      unidentified += foreign;
      std::uint64_t not_good = 0;
      for (const auto& [status, n] : s.by_status)
        if (status != "good") not_good += n;
      const std::uint64_t good = s.by_status.count("good") ? s.by_status.at("good") - duplicates : 0;
      const std::uint64_t incomplete = not_good - std::min(not_good, unidentified);
      const std::uint64_t behind = s.not_kept.count("encoder_behind") ? s.not_kept.at("encoder_behind") : 0;
      // Lost because pvcap did not take them in time (its queue full, no free stream buffer).
      std::uint64_t pvcap_behind = 0;
      for (const char* why : {"queue_overflow", "buffer_underrun"})
        if (s.dropped_by_reason.count(why)) pvcap_behind += s.dropped_by_reason.at(why);
      fmt::format_to(out, "{:<8} {:>9} {:>9} {:>9} {:>11} {:>12} {:>12} {:>11} {:>9}\n", s.name, s.frames, good,
                     s.in_video, incomplete, s.dropped - pvcap_behind, pvcap_behind, behind, s.connection_losses);
      any_loss |= incomplete + s.dropped + behind + s.connection_losses > 0;
      if (unidentified + duplicates > foreign)
        notes += fmt::format(
            "{}: {} buffers arrived without their own frame id (reasons no_frame_id_*, "
            "stale_metadata_*, duplicate_frame_id); the frames they were are counted as not received\n",
            s.name, unidentified + duplicates - foreign);
      if (foreign)
        notes += fmt::format(
            "{}: {} frames of another camera (another size or pixel format) reached its stream and were refused "
            "(reason foreign_frame_*)\n",
            s.name, foreign);
    } else {
      notes += fmt::format("{:<8} {:>9} frames stored, {} missing by its counter, {} connection losses\n", s.name,
                           s.frames, s.dropped, s.connection_losses);
      any_loss |= s.dropped + s.connection_losses > 0;
    }
  }
  fmt::format_to(out, "{}", notes);
  double sample_hz = 0;
  if (const auto n = r.sample_count(); n >= 2) {
    auto first = r.sample_info(0), last = r.sample_info(n - 1);
    if (!first) return first.error();  // the index cannot be read: no figure is made up in its place
    if (!last) return last.error();
    if (last.value().tick != first.value().tick)
      sample_hz =
          double(last.value().tick - first.value().tick) / (double(last.value().tick_ns - first.value().tick_ns) / 1e9);
  }
  fmt::format_to(out,
                 "samples: {} at {:.3g} Hz ({} groups complete, {} with a camera missing, {} ticks without any "
                 "group)\n",
                 r.sample_count(), sample_hz, count_of("groups_complete"), count_of("groups_incomplete"),
                 count_of("ticks_without_a_group"));
  if (const auto late = count_of("camera_frames_late_for_their_instant"))
    fmt::format_to(out, "{} camera frames came too late for their instant's group\n", late);
  for (const auto& [what, n] : counts.value()) {
    if (starts_with(what, "unpaired: ")) fmt::format_to(out, "{} samples without pressure: {}\n", n, what.substr(10));
    if (starts_with(what, "clock_resets: "))
      fmt::format_to(out, "{}: its clock was reset {} time(s); each started a new clock-model segment\n",
                     what.substr(14), n);
  }
  fmt::format_to(out,
                 "video keeps one frame per camera per sample; every received frame is in session.db with its "
                 "reason\n");
  if (any_loss)
    fmt::format_to(out, "frames were lost: see the drops and frames tables (reason column) in session.db\n");
  return fmt::to_string(buf);
}

ClosingReport closing_report(const std::filesystem::path& dir, std::optional<double> recorded_s,
                             const std::vector<std::string>& notes, bool protocol) {
  ClosingReport out;
  auto text = session_text(dir, recorded_s);
  if (!text) out.errors.push_back(fmt::format("the report could not be made: {}", text.error().message));
  out.file = text ? text.value()
                  : fmt::format("session: {}\nthe report could not be made: {}\n", dir.string(), text.error().message);
  for (const auto& note : notes) out.file += note + "\n";
  out.terminal = "\n" + out.file;
  if (!protocol) return out;
  auto takes = protocol::read_takes(dir);
  if (!takes) {
    out.errors.push_back(fmt::format("the takes could not be read back: {}", takes.error().message));
    return out;
  }
  // Every take in report.txt (and report.html); the terminal keeps to the totals.
  const std::string table = protocol::format_takes(takes.value());
  out.file += "\n" + table;
  const auto at = table.find(" takes done of ");
  out.terminal += "\n" + (at == std::string::npos ? table : table.substr(table.rfind('\n', at) + 1));
  return out;
}

}  // namespace pvcap::report
