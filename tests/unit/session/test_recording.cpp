// The recording engine alone, through a store the test gives it (storage/writer/recording_store.h):
// a start, what it writes, a store's fault and a stop, without devices and without a session folder.
// The rig has no camera and no Sensel; what the devices add is the integration tests' (tests/integration).
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/rig_config.h"
#include "session/recording.h"
#include "storage/writer/recording_store.h"
#include "tests/unit/temp_dir.h"

using namespace pvcap;
using namespace std::chrono_literals;

namespace {

// What the store was given, shared with the test (the recording owns the store).
struct Seen {
  std::mutex mu;
  bool started = false;
  std::optional<std::string> closed_with;
  std::vector<ProtocolEventRecord> protocol_events;
  std::vector<OperatorNoteRecord> notes;
  std::vector<EventRecord> events;
  std::vector<std::pair<std::string, std::uint64_t>> timeline_counts;
  std::optional<ConditionsRecord> conditions;
  std::optional<std::string> failure;  // set by the test: the store's fault
  bool commit = true;                  // false: a store that cannot commit (an index held up)
};

class TestStore : public RecordingStore {
 public:
  TestStore(std::shared_ptr<Seen> seen, std::filesystem::path dir) : seen_(std::move(seen)), dir_(std::move(dir)) {}
  Result<std::int64_t> add_camera(const DeviceRecord&, int, int, const std::string&) override { return next_id_++; }
  bool stores_raw(std::int64_t) const override { return false; }
  PlaneOrder raw_plane_order(std::int64_t) const override { return kCellOrder; }
  Result<std::int64_t> add_device(const DeviceRecord&) override { return next_id_++; }
  Status set_participant(const ParticipantRecord&) override { return {}; }
  Status set_conditions(const ConditionsRecord& c) override {
    std::lock_guard lock(seen_->mu);
    seen_->conditions = c;
    return {};
  }
  Result<std::int64_t> add_calibration(const CalibrationRecord&) override { return 1; }
  void start() override {
    std::lock_guard lock(seen_->mu);
    seen_->started = true;
  }
  void record(FrameRecord) override {}
  void record(DropRecord) override {}
  void record(PressureRecord) override {}
  void record(EventRecord e) override {
    std::lock_guard lock(seen_->mu);
    seen_->events.push_back(std::move(e));
  }
  void record(SampleRecord) override {}
  void record(ClockModelRecord) override {}
  void record(ProtocolEventRecord e) override { (void)record_committed(std::move(e), 0ms); }
  void record(OperatorNoteRecord n) override { (void)record_committed(std::move(n), 0ms); }
  bool record_committed(ProtocolEventRecord e, std::chrono::milliseconds) override {
    std::lock_guard lock(seen_->mu);
    if (!seen_->commit) return false;
    seen_->protocol_events.push_back(std::move(e));
    return true;
  }
  bool record_committed(OperatorNoteRecord n, std::chrono::milliseconds) override {
    std::lock_guard lock(seen_->mu);
    if (!seen_->commit) return false;
    seen_->notes.push_back(std::move(n));
    return true;
  }
  void add_timeline_count(std::string what, std::uint64_t count) override {
    std::lock_guard lock(seen_->mu);
    seen_->timeline_counts.emplace_back(std::move(what), count);
  }
  bool submit_video(std::int64_t, cv::Mat, FrameRecord) override { return true; }
  bool writes_failed() const override { return false; }
  void add_stream_stats(const StreamStatsRecord&) override {}
  std::optional<std::string> failure() const override {
    std::lock_guard lock(seen_->mu);
    return seen_->failure;
  }
  void set_finalizer(std::function<void(SessionIndex&)>) override {}
  Status close(const std::string& end_reason) override {
    std::lock_guard lock(seen_->mu);
    seen_->closed_with = end_reason;
    return {};
  }
  const std::filesystem::path& dir() const override { return dir_; }
  CameraStoreStats camera_stats(std::int64_t) const override { return {}; }
  std::uint64_t index_records_lost() const override { return 0; }
  std::uint64_t index_records_waited() const override { return 0; }
  std::string index_records_lost_by_kind() const override { return ""; }

 private:
  std::shared_ptr<Seen> seen_;
  std::filesystem::path dir_;
  std::int64_t next_id_ = 1;
};

// A rig of no devices (its file in `dir`: the rig lock is named after it) and the options that give
// the recording a TestStore.
struct Bench {
  pvcap::testing::TempDir scratch{
      pvcap::testing::fresh_temp_dir("recording", ::testing::UnitTest::GetInstance()->current_test_info()->name())};
  std::shared_ptr<Seen> seen = std::make_shared<Seen>();
  RigConfig rig;
  session::RecordingOptions options;
  std::atomic<bool> cancel{false}, interrupt{false};

  Bench() {
    rig.name = "no-devices";
    rig.source = scratch.path / "rig.yaml";
    std::ofstream(rig.source) << "name: no-devices\n";
    rig.store.video_fps = 15;
    options.root = scratch.path / "sessions";
    options.conditions = ConditionsRecord{"LCR", "white_vinyl"};
    options.make_store = [seen = seen, dir = scratch.path / "session"](
                             const RigConfig&, std::int64_t, std::int64_t) -> Result<std::unique_ptr<RecordingStore>> {
      std::filesystem::create_directories(dir);
      return std::unique_ptr<RecordingStore>(std::make_unique<TestStore>(seen, dir));
    };
  }
};

}  // namespace

TEST(Recording, ItWritesIntoTheStoreItIsGivenAndClosesItWithTheStopsReason) {
  Bench b;
  auto opened = session::Recording::open(b.rig, b.options, b.cancel);
  ASSERT_TRUE(opened) << opened.error().message;
  session::Recording& rec = *opened.value();
  EXPECT_FALSE(rec.post(ProtocolEventRecord{0, "prompt", 1, "press", "right", "low", 1, "{}"}))
      << "nothing is acknowledged before the store exists";
  ASSERT_TRUE(rec.start().ok());
  {
    std::lock_guard lock(b.seen->mu);
    EXPECT_TRUE(b.seen->started);
    ASSERT_TRUE(b.seen->conditions);
    EXPECT_EQ(b.seen->conditions->lighting, "LCR");
  }
  EXPECT_EQ(rec.dir(), b.scratch.path / "session");
  EXPECT_EQ(rec.status().state, "recording");

  // Protocol events and notes are committed before they are acknowledged, stamped when unstamped.
  ASSERT_TRUE(rec.post(ProtocolEventRecord{0, "action_start", 1, "press", "right", "low", 1, "{}"}));
  ASSERT_TRUE(rec.note("participant sneezed"));
  {
    std::lock_guard lock(b.seen->mu);
    ASSERT_EQ(b.seen->protocol_events.size(), 1u);
    EXPECT_EQ(b.seen->protocol_events[0].kind, "action_start");
    EXPECT_GE(b.seen->protocol_events[0].host_ns, rec.started_host_ns()) << "stamped on the capture clock";
    ASSERT_EQ(b.seen->notes.size(), 1u);
    EXPECT_EQ(b.seen->notes[0].text, "participant sneezed");
    b.seen->commit = false;  // an index held up: nothing is acknowledged that is not committed
  }
  EXPECT_FALSE(rec.post(ProtocolEventRecord{0, "action_end", 1, "press", "right", "low", 1, "{}"}));

  rec.request_stop("protocol complete");
  EXPECT_EQ(rec.wait(b.interrupt, std::nullopt), "protocol complete");
  const session::RecordingResult result = rec.finish("protocol complete");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_EQ(result.dir, b.scratch.path / "session");
  std::lock_guard lock(b.seen->mu);
  EXPECT_EQ(b.seen->closed_with, "protocol complete");
  bool samples_counted = false;
  for (const auto& [what, n] : b.seen->timeline_counts) samples_counted = samples_counted || what == "samples";
  EXPECT_TRUE(samples_counted) << "the timeline's tallies reach the store at close";
}

TEST(Recording, AStoreThatFailsStopsTheRecordingWithItsReason) {
  Bench b;
  auto opened = session::Recording::open(b.rig, b.options, b.cancel);
  ASSERT_TRUE(opened) << opened.error().message;
  session::Recording& rec = *opened.value();
  ASSERT_TRUE(rec.start().ok());
  {
    std::lock_guard lock(b.seen->mu);
    b.seen->failure = "the disk is full";
  }
  const std::string reason = rec.wait(b.interrupt, 30.0);  // the store's fault, long before the duration
  EXPECT_EQ(reason, "storage failure: the disk is full");
  (void)rec.finish(reason);
  std::lock_guard lock(b.seen->mu);
  EXPECT_EQ(b.seen->closed_with, reason) << "the store is closed with the reason it stopped for";
}

TEST(Recording, AStoreThatCannotBeMadeFailsTheStartAndNothingRecords) {
  Bench b;
  b.options.make_store = [](const RigConfig&, std::int64_t, std::int64_t) -> Result<std::unique_ptr<RecordingStore>> {
    return Error{"/sessions: read-only file system"};
  };
  auto opened = session::Recording::open(b.rig, b.options, b.cancel);
  ASSERT_TRUE(opened) << opened.error().message;
  const Status started = opened.value()->start();
  ASSERT_FALSE(started.ok());
  EXPECT_EQ(started.error().message, "/sessions: read-only file system");
  EXPECT_EQ(opened.value()->finish("never started").exit_code, 1);
}
