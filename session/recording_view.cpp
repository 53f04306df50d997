// What a running recording shows of itself while it records (session/recording_status.h): the
// status snapshot the console, the pages and the tests read, the cameras' previews and the pressure
// now and over a window. Read from their threads; the capture path only publishes.
#include "session/recording.h"

#include <algorithm>
#include <filesystem>

#include "core/time.h"
#include "session/camera_pipeline.h"
#include "storage/writer/session_writer.h"

namespace pvcap::session {

RecordingStatus Recording::status() const {
  RecordingStatus st;
  st.state = kStates[state_.load()];
  const std::int64_t now = host_now().ns;
  if (writer_) st.session_dir = writer_->dir().string();
  if (rec_start_) st.elapsed_s = double(now - rec_start_) / 1e9;
  // A frame stamped after `now` was read (it arrived meanwhile) is 0 ms old, not "none yet" (-1).
  auto since = [&](std::int64_t t) { return t > 0 ? std::max(0.0, double(now - t) / 1e6) : -1.0; };
  std::lock_guard lock(mu_);
  rate_marks_.resize(cameras_.size() + (sensel_ ? 1 : 0));
  rates_.resize(rate_marks_.size(), 0.0);
  // Rates over at least half a second since the last status() that measured them.
  auto rate = [&](std::size_t k, std::uint64_t count) {
    auto& [t, c] = rate_marks_[k];
    if (t == 0) t = now, c = count;
    if (now - t >= 500'000'000) {
      rates_[k] = double(count - c) / (double(now - t) / 1e9);
      t = now;
      c = count;
    }
    return rates_[k];
  };
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    const auto& t = *tallies_[i];
    StreamStatus s;
    s.name = rig_.cameras[i].name;
    s.kind = "camera";
    s.received = t.received.load();
    s.good = t.good.load();
    s.incomplete = t.incomplete.load();
    s.not_received = t.not_received.load();
    s.buffer_underrun = t.buffer_underrun.load();
    s.encoder_behind = t.encoder_behind.load();
    s.connection_losses = t.lost_events.load();
    if (writer_) {
      const auto cs = writer_->camera_stats(device_ids_[i]);
      s.in_video = cs.frames_in_video;
      s.encoder_backlog = cs.encoder_backlog;
      s.spill_backlog = cs.spill_backlog;
      s.spilled = cs.spilled;
    }
    s.rate_hz = rate(i, s.good);
    s.since_last_frame_ms = since(t.last_good_host_ns.load());
    st.streams.push_back(std::move(s));
  }
  if (sensel_) {
    StreamStatus s;
    s.name = "sensel";
    s.kind = "sensel";
    s.received = s.good = sensel_->stored();
    s.not_received = sensel_->lost_frames();
    s.queue_overflow = sensel_->queue_overflows();
    s.rate_hz = rate(cameras_.size(), s.good);
    s.since_last_frame_ms = since(sensel_->last_frame_host_ns());
    st.streams.push_back(std::move(s));
  }
  st.samples = samples_.load();
  if (!recent_offsets_ms_.empty()) {
    double sum = 0, mx = 0;
    for (double o : recent_offsets_ms_) sum += o, mx = std::max(mx, o);
    st.pressure_offset_mean_ms = sum / double(recent_offsets_ms_.size());
    st.pressure_offset_max_ms = mx;
  }
  if (writer_) {
    std::error_code ec;
    const auto space = std::filesystem::space(writer_->dir(), ec);
    if (!ec) st.free_disk_bytes = std::int64_t(space.available);
  }
  st.warnings.assign(warnings_.begin(), warnings_.end());
  return st;
}

std::pair<cv::Mat, std::int64_t> Recording::preview_full(std::size_t camera, std::int64_t newer_than_ns) const {
  if (camera >= previews_.size()) return {};
  return previews_[camera]->get_full(newer_than_ns);
}

std::pair<cv::Mat, std::int64_t> Recording::preview(std::size_t camera) const {
  if (camera >= previews_.size()) return {};
  return previews_[camera]->get();
}

std::optional<PressureSnapshot> Recording::pressure_now() const {
  if (!sensel_) return std::nullopt;
  return sensel_->latest();
}

std::vector<PressurePoint> Recording::pressure_history(std::int64_t from_ns, std::int64_t to_ns) const {
  if (!sensel_) return {};
  return sensel_->history(from_ns, to_ns);
}

}  // namespace pvcap::session
