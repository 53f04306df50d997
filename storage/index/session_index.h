#pragma once
// The session index (session.db): schema and the statements that fill it.
// Single-threaded: the IndexWriter's thread is its only user while recording.
// The schema is documented in docs/store.md; kSchemaVersion is PRAGMA user_version.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "storage/index/database.h"
#include "storage/index/record_codec.h"
#include "storage/index/records.h"
#include "storage/index/schema.h"

namespace pvcap {

class SessionIndex {
 public:
  // Creates a new index at `path` (which must not exist) with the current schema.
  static SessionIndex create(const std::filesystem::path& path);
  // Opens an existing index for writing (recover, migrate), upgrading its schema first (after
  // a backup copy) when it is older. `migrated` receives the versions passed through.
  static SessionIndex open_for_update(const std::filesystem::path& path, std::vector<int>* migrated = nullptr,
                                      const std::function<void(const std::string&)>& progress = nullptr);

  std::int64_t add_session(const SessionRecord& s);
  std::int64_t add_device(const DeviceRecord& d);
  void add_video_file(const VideoFileRecord& v);
  void close_video_file(const VideoFileClosed& v);
  void set_participant(const ParticipantRecord& p);
  void set_conditions(const ConditionsRecord& c);
  std::int64_t add_calibration(const CalibrationRecord& c);
  void add_protocol_event(const ProtocolEventRecord& e);
  void add_operator_note(const OperatorNoteRecord& n);
  void add_frame(const FrameRecord& f);
  void add_drop(const DropRecord& d);
  void add_pressure(const PressureRecord& p);
  void add_event(const EventRecord& e);
  void add_stream_stats(const StreamStatsRecord& s);
  void add_sample(const SampleRecord& s);
  void add_clock_model(const ClockModelRecord& c);
  void add_timeline_count(const std::string& what, std::uint64_t count);
  void finish_session(std::int64_t ended_host_ns, const std::string& end_reason);

  // Any index record, by its kind (what the index thread writes, and recover replays).
  void add(const IndexRecord& record);
  // Whether the index holds `record` already, by its kind's key (frames and pressure frames: device,
  // connection and sequence; samples and video files: their id; a close: the file closed with its
  // count; the others: their instant and what they say): a record written twice is written once.
  bool holds(const IndexRecord& record);

  // Re-mapping a finished recording with its final clock fits (see docs/store.md).
  enum class Stream { Camera, Pressure };  // frames (arrival host_ns) / pressure_frames (answer arrival)
  // Sets mapped_ns = device_ns + offset + skew * (device_ns - x0) - latency for the stream's rows
  // that arrived in [from_arrival_ns, to_arrival_ns) and have a mapped time.
  void remap(Stream stream, std::int64_t device_id, std::int64_t from_arrival_ns, std::int64_t to_arrival_ns,
             std::int64_t x0, double offset_ns, double skew, std::int64_t latency_ns);
  struct MappedRef {
    std::uint32_t connection = 0;
    std::uint64_t sequence = 0;
    std::int64_t mapped_ns = 0;
  };
  std::vector<MappedRef> mapped(Stream stream, std::int64_t device_id);
  // Each stream's clock segments as the store holds them: begun at the segment's first row (its
  // arrival time), fitted as its last row says; streams by device, segments in order.
  struct StoredSegment {
    std::int64_t first_arrival_ns = 0;
    std::int64_t x0 = 0, latency_ns = 0;
    double offset_ns = 0, skew = 0;
  };
  struct StoredClocks {
    std::int64_t device_id = 0;
    bool pressure = false;
    std::vector<StoredSegment> segments;
  };
  std::vector<StoredClocks> stored_clocks();
  // The re-mapping was started and not finished (interrupted), or a session recorded with the
  // re-mapping in steps never got to it: a realign_started event with no realign_done after it.
  bool realign_pending();
  // Every sample with its stored instant and camera frames (none when the sample names no frame).
  struct SampleMembers {
    std::uint64_t id = 0;
    std::int64_t tick_ns = 0, t_ns = 0, span_ns = 0;
    std::vector<SampleFrameRef> frames;
  };
  std::vector<SampleMembers> sample_members();
  // The rig file the session recorded with: its text and the path it was read from (none: no session row).
  struct RecordedRig {
    std::string text, path;
  };
  std::optional<RecordedRig> recorded_rig();
  // The device's name in the rig (cam0, sensel); "device N" for an id the session does not know.
  std::string device_name(std::int64_t device_id);
  // Rewrites a sample's instant, its frames' offsets and its pressure pairing.
  void update_sample(const SampleRecord& s);
  // Takes a camera frame out of its sample (the final clock fits put it outside the group's span
  // limit): its sample_frames row goes, the sample counts one camera less, and the frame, still in
  // its video, gets the reason `outside_its_group`.
  void leave_sample(std::uint64_t sample_id, const SampleFrameRef& frame);

  sqlite::Database& db() { return *db_; }

 private:
  explicit SessionIndex(std::unique_ptr<sqlite::Database> db);
  std::unique_ptr<sqlite::Database> db_;
  std::optional<sqlite::Statement> insert_frame_, insert_drop_, insert_event_, insert_pressure_, insert_sample_,
      insert_sample_frame_, insert_clock_, update_sample_, update_sample_frame_;
};

}  // namespace pvcap
