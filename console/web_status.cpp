#include "console/web_status.h"

#include <cmath>

#include <fmt/format.h>

#include "codec/sensel_units.h"

namespace pvcap::console {

namespace {

nlohmann::json stream_json(const session::StreamStatus& s) {
  return {{"name", s.name},
          {"kind", s.kind},
          {"received", s.received},
          {"good", s.good},
          {"in_video", s.in_video},
          {"incomplete", s.incomplete},
          {"not_received", s.not_received},
          {"queue_overflow", s.queue_overflow},
          {"buffer_underrun", s.buffer_underrun},
          {"encoder_behind", s.encoder_behind},
          {"connection_losses", s.connection_losses},
          {"encoder_backlog", s.encoder_backlog},
          {"spill_backlog", s.spill_backlog},
          {"spilled", s.spilled},
          {"rate_hz", std::round(s.rate_hz * 10) / 10},
          {"since_last_frame_ms", std::round(s.since_last_frame_ms)}};
}

}  // namespace

nlohmann::json status_model(const session::RecordingStatus& st, std::size_t cameras,
                            const std::optional<session::PressureSnapshot>& pressure, PageCounts pages,
                            const protocol::RunnerView* runner) {
  nlohmann::json j;
  const bool live = st.all_live(kLiveWindowMs);
  nlohmann::json streams = nlohmann::json::array();
  for (const auto& s : st.streams) streams.push_back(stream_json(s));
  j["session"] = {{"state", st.state},
                  {"dir", st.session_dir},
                  {"elapsed_s", std::round(st.elapsed_s * 10) / 10},
                  {"samples", st.samples},
                  {"pressure_offset_mean_ms", std::round(st.pressure_offset_mean_ms * 100) / 100},
                  {"pressure_offset_max_ms", std::round(st.pressure_offset_max_ms * 100) / 100},
                  {"free_disk_gb", st.free_disk_bytes < 0 ? -1.0 : std::round(double(st.free_disk_bytes) / 1e8) / 10},
                  {"warnings", st.warnings},
                  {"streams", streams},
                  {"cameras", cameras},
                  {"devices_live", live}};
  j["pages"] = {{"participant", pages.participant}, {"operator", pages.operator_pages}};
  if (const auto& p = pressure; p && !p->counts.empty()) {
    const auto sum = sensel::summarize_pressure(p->counts, p->grid);
    j["pressure"] = {{"total_newtons", std::round(sum.total_newtons * 100) / 100},
                     {"contact_mm2", std::round(sum.contact_area_mm2)}};
  }
  if (!runner) {
    j["protocol"] = false;
    j["recording_indicator"] = st.state == "recording" && live;
    return j;
  }
  const protocol::RunnerView& v = *runner;
  j["protocol"] = true;
  j["phase"] = protocol::to_string(v.phase);
  j["paused_in"] = protocol::to_string(v.paused_in);
  j["step"] = v.step;
  j["steps"] = v.steps;
  j["takes_done"] = v.takes_done;
  j["sequence"] = v.sequence;
  j["action"] = v.action_name;
  j["text"] = v.action_text;
  j["pictogram"] = v.pictogram.empty() ? "" : fmt::format("/pictogram/{}", v.step);
  j["force"] = v.force;
  j["hand"] = v.hand;
  j["repetition"] = v.repetition;
  j["repetitions"] = v.repetitions;
  j["seconds_left"] = std::round(v.seconds_left * 10) / 10;
  j["waiting_for_devices"] = v.waiting_for_devices;
  j["holding"] = v.holding;
  j["message"] = v.message;
  j["step_status"] = v.step_status;
  // "Recording" is shown only while every device delivers: the participant never performs into a gap.
  j["recording_indicator"] = v.phase == protocol::Phase::Recording && live;
  if (v.last) {
    nlohmann::json last = {{"sequence", v.last->sequence}, {"status", v.last->status}};
    if (v.last->check) {
      last["check_ok"] = v.last->check->ok;
      last["problems"] = v.last->check->problems;
      last["mean_newtons"] = std::round(v.last->check->measures.mean_newtons * 100) / 100;
      last["peak_newtons"] = std::round(v.last->check->measures.peak_newtons * 100) / 100;
    }
    j["last"] = last;
  }
  return j;
}

}  // namespace pvcap::console
