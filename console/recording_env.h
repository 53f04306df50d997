#pragma once
// The protocol runner and the session's pages attached to a running recording: events committed to
// its store, device liveness from its status, the take check's pressure from its Sensel pipeline,
// the previews. An automatic participant (a simulated rig's hand) decorates the runner's environment
// from outside (app/).
#include "console/page_source.h"
#include "protocol/runner.h"
#include "session/recording.h"

namespace pvcap::console {

class RecordingEnv : public protocol::RunnerEnv {
 public:
  explicit RecordingEnv(session::Recording& recording);

  std::int64_t now_ns() override;
  bool commit(const ProtocolEventRecord& event) override;
  bool commit_note(const std::string& text) override;
  bool devices_live() override;
  double stream_silence_ms() override;
  bool has_pressure() override;
  std::vector<protocol::ForcePoint> pressure(std::int64_t from_ns, std::int64_t to_ns) override;
  std::optional<std::string> set_lighting(const std::string& code) override { return recording_.set_lighting(code); }
  std::string lighting_seen(std::int64_t from_ns, std::int64_t to_ns) override {
    return recording_.lighting_seen(from_ns, to_ns);
  }
  std::string lighting_now() override { return recording_.lighting_now(); }

  static constexpr double kLiveWindowMs = 250;  // "delivered frames in the last 250 ms"

 private:
  session::Recording& recording_;
};

class RecordingPages : public PageSource {
 public:
  explicit RecordingPages(session::Recording& recording) : recording_(recording) {}

  session::RecordingStatus status() const override { return recording_.status(); }
  std::size_t camera_count() const override { return recording_.rig().cameras.size(); }
  std::pair<cv::Mat, std::int64_t> preview(std::size_t camera, bool full) const override {
    return full ? recording_.preview_full(camera) : recording_.preview(camera);
  }
  std::optional<session::PressureSnapshot> pressure_now() const override { return recording_.pressure_now(); }
  bool post(ProtocolEventRecord event) override { return recording_.post(std::move(event)); }
  void request_stop(std::string reason) override { recording_.request_stop(std::move(reason)); }

 private:
  session::Recording& recording_;
};

}  // namespace pvcap::console
