// Index rows that wait while the index is behind (storage/index_overflow.h): encoded and read back
// whole, in their order, through memory and the file; a slow index loses none of them.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <thread>

#include "storage/index_overflow.h"
#include "storage/index_writer.h"
#include "storage/record_codec.h"
#include "storage/sqlite/database.h"

namespace fs = std::filesystem;
using namespace pvcap;
using namespace std::chrono_literals;

namespace {
// Removed when the test ends, also when an assertion ends it early.
struct TempDir {
  fs::path path;
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

fs::path overflow_dir(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("pvcap-test-overflow-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

FrameRecord frame(std::uint64_t i) {
  FrameRecord r{3,
                1,
                i,
                i + 100,
                std::int64_t(i) * 1000,
                std::int64_t(i) * 2000,
                7,
                "good",
                true,
                "",
                4,
                std::int64_t(i),
                std::int64_t(i) * 3000,
                std::int64_t(i) * 66,
                std::uint32_t(i * 2654435761u)};
  return r;
}

// Every kind, every field away from its default.
std::vector<IndexRecord> one_of_each() {
  PressureRecord p{9, 2, 41, 3, -5, 6, 7, 47, 27, 4, 4, {1, 2, 3, 250}, 99, 3, {0, 7, 65535}, 0xdeadbeef};
  SampleRecord s{12,
                 13,
                 14,
                 15,
                 16,
                 {{3, 1, 5, -7}, {4, 0, 6, 8}},
                 SampleFrameRef{9, 2, 41, 100},
                 SampleFrameRef{9, 2, 40, -8000},
                 std::nullopt};
  ClockModelRecord c{3, 1000, 2, -4, 1.5e9, -2.5e-6, 300, "latch", 77, 12, 40, 9000};
  VideoFileRecord v{5, 3, "cam0-001.mkv", "ffvhuff", "gray", 1920, 1080, 1, "bayer_planes", "BayerRG8", 8};
  ProtocolEventRecord e{123, "action_start", 4, "press_palm", "left", "high", 2, "{\"x\":1}"};
  return {frame(5),
          p,
          DropRecord{3, 1, 10, 4, "not_received", 55},
          EventRecord{66, "camera_lost", 3, "cam0 went away"},
          s,
          c,
          v,
          VideoFileClosed{5, 900},
          e,
          OperatorNoteRecord{77, "participant sneezed"}};
}
}  // namespace

TEST(RecordCodec, EveryKindReadsBackAsItWasAndACutRecordIsNoRecord) {
  std::string bytes;
  const auto records = one_of_each();
  ASSERT_EQ(records.size(), std::variant_size_v<IndexRecord>);
  for (const auto& r : records) encode_record(r, bytes);
  std::size_t pos = 0;
  for (const auto& r : records) {
    auto back = decode_record(bytes, pos);
    ASSERT_TRUE(back);
    EXPECT_EQ(back->index(), r.index());
    EXPECT_TRUE(*back == r) << "kind " << r.index();
  }
  EXPECT_EQ(pos, bytes.size());
  // Cut anywhere inside the last record: no record, and the position stays.
  std::string one;
  encode_record(records[1], one);
  for (std::size_t cut = 0; cut < one.size(); ++cut) {
    std::size_t at = 0;
    EXPECT_FALSE(decode_record(one.substr(0, cut), at)) << cut;
    EXPECT_EQ(at, 0u);
  }
}

TEST(IndexOverflow, RecordsLeaveInTheirOrderThroughMemoryAndTheFile) {
  const TempDir scratch{overflow_dir("order")};
  const fs::path& dir = scratch.path;
  const fs::path file = dir / "spill" / kIndexOverflowFile;
  std::vector<std::uint64_t> out;
  {
    IndexOverflow overflow(file, 50);
    auto barrier = std::make_shared<std::promise<bool>>();
    auto answered = barrier->get_future();
    overflow.add(CommitBarrier{barrier});  // oldest: it will have to go to the file
    for (std::uint64_t i = 0; i < 5000; ++i) overflow.add(frame(i));
    // The spill thread moves the oldest to the file; the barrier among them is refused.
    ASSERT_EQ(answered.wait_for(5s), std::future_status::ready);
    EXPECT_FALSE(answered.get());
    for (int i = 0; i < 500 && overflow.spilled() < 4000; ++i) std::this_thread::sleep_for(10ms);
    EXPECT_GE(overflow.spilled(), 4000u) << "the memory bound is 50 records";
    EXPECT_TRUE(fs::exists(file));
    for (std::uint64_t i = 5000; i < 6000; ++i) overflow.add(frame(i));  // while it drains
    while (!overflow.empty())
      for (auto& item : overflow.take()) out.push_back(std::get<FrameRecord>(item).sequence);
    EXPECT_FALSE(overflow.failure());
    EXPECT_EQ(overflow.lost(), 0u);
  }
  ASSERT_EQ(out.size(), 6000u);
  for (std::uint64_t i = 0; i < out.size(); ++i) ASSERT_EQ(out[i], i);
  EXPECT_FALSE(fs::exists(file)) << "removed once read back";
}

// The index thread stalls with a queue of 100 records and 200 in memory: 20,000 rows pushed meanwhile
// all reach session.db, in order, none lost, and the index says it was behind.
TEST(IndexWriter, AStalledIndexLosesNoRowAndSaysItWasBehind) {
  const TempDir scratch{overflow_dir("stall")};
  const fs::path& dir = scratch.path;
  const fs::path file = dir / "spill" / kIndexOverflowFile;
  {
    SessionIndex index = SessionIndex::create(dir / "session.db");
    index.add_session({1, 2, "test", "rig", "rig.yaml", "name: rig", true});
    const std::int64_t cam = index.add_device({"camera", "cam0", "", "", "", "", "", "{}"});
    IndexWriter writer(index, 100, 50ms, Stall{1.5, 0.1}, file, 200);
    writer.start();
    for (std::uint64_t i = 0; i < 20'000; ++i) {
      FrameRecord r = frame(i);
      r.device_id = cam;
      r.video_file_id.reset();
      r.video_index.reset();
      r.kept = false;
      r.reason = "subsampled";
      EXPECT_TRUE(writer.push(r));
      if (i % 1000 == 0) std::this_thread::sleep_for(20ms);  // ~0.4 s: the stall begins meanwhile
    }
    writer.stop();
    EXPECT_EQ(writer.records_lost(), 0u);
    EXPECT_GT(writer.records_waited(), 10'000u);
    EXPECT_GT(writer.records_waited_on_disk(), 5'000u);
    EXPECT_FALSE(writer.failure());
  }
  sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT sequence FROM frames ORDER BY rowid");
  std::uint64_t expect = 0;
  while (q.step()) ASSERT_EQ(std::uint64_t(q.column_int(0)), expect++);
  EXPECT_EQ(expect, 20'000u);
  auto e = db.prepare("SELECT message FROM events WHERE kind = 'index_behind'");
  ASSERT_TRUE(e.step());
  EXPECT_NE(e.column_text(0).find("none was lost"), std::string::npos) << e.column_text(0);
  EXPECT_FALSE(fs::exists(file));
}
