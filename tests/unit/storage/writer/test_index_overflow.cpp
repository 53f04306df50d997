// Index rows that wait while the index is behind (storage/writer/index_overflow.h): encoded and read back
// whole, in their order, through memory and the file; a slow index loses none of them; the journal
// (storage/writer/index_journal.h) holds the rows not yet committed, for recover.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>

#include "storage/index/database.h"
#include "storage/index/record_codec.h"
#include "storage/index/session_index.h"
#include "storage/writer/index_journal.h"
#include "storage/writer/index_overflow.h"
#include "storage/writer/index_writer.h"
#include "storage/writer/recover.h"
#include "tests/unit/temp_dir.h"

namespace fs = std::filesystem;
using namespace pvcap;
using namespace std::chrono_literals;

namespace {
using pvcap::testing::TempDir;

fs::path overflow_dir(const std::string& name) { return pvcap::testing::fresh_temp_dir("overflow", name); }

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
                std::uint32_t(i * 2654435761u),
                std::int64_t(i) + 70000,
                std::int64_t(i) * 1000 - 3,
                6000.5,
                2.25,
                std::int64_t(i % 16)};
  return r;
}

// A frame's row as a camera's frame that the samples passed over: in no video, so it needs no video file.
FrameRecord unkept_frame(std::uint64_t i, std::int64_t camera) {
  FrameRecord r = frame(i);
  r.device_id = camera;
  r.video_file_id.reset();
  r.video_index.reset();
  r.kept = false;
  r.reason = "subsampled";
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

// A journal an older pvcap left (codec version 1: frames without their line levels) reads back in its
// own field list, beside chunks of the current one in the same file.
TEST(RecordCodec, AnOlderPvcapsChunksReadInTheirOwnVersion) {
  const auto records = one_of_each();
  std::string bytes;
  encode_record_chunk(records, bytes, 1);
  encode_record_chunk(records, bytes);
  const RecordChunks back = decode_record_chunks(bytes);
  EXPECT_EQ(back.unreadable_bytes, 0u);
  ASSERT_EQ(back.records.size(), 2 * records.size());
  FrameRecord old_frame = std::get<FrameRecord>(records[0]);
  old_frame.chunk_line_status.reset();  // version 1 had no line levels
  EXPECT_TRUE(std::get<FrameRecord>(back.records[0]) == old_frame);
  for (std::size_t i = 1; i < records.size(); ++i) EXPECT_TRUE(back.records[i] == records[i]) << "kind " << i;
  for (std::size_t i = 0; i < records.size(); ++i)
    EXPECT_TRUE(back.records[records.size() + i] == records[i]) << "kind " << i;
  // Read in the wrong version, a frame's bytes are no record: the magic is what keeps them apart.
  std::string frame_bytes;
  encode_record(records[0], frame_bytes, 1);
  std::size_t at = 0;
  const auto misread = decode_record(frame_bytes, at, 2);
  EXPECT_FALSE(misread && at == frame_bytes.size());
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
      EXPECT_TRUE(writer.push(unkept_frame(i, cam)));
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

namespace {
// The frames table, row by row, as text: what two recovers must leave the same.
std::string frames_table(const fs::path& db_path) {
  sqlite::Database db(db_path, sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT device_id, connection, sequence, host_ns, video_index FROM frames ORDER BY rowid");
  std::string out;
  while (q.step())
    out += std::to_string(q.column_int(0)) + "," + std::to_string(q.column_int(1)) + "," +
           std::to_string(q.column_int(2)) + "," + std::to_string(q.column_int(3)) + "," +
           std::to_string(q.column_int(4)) + "\n";
  return out;
}
}  // namespace

// A recording cut while its index was behind leaves rows in the overflow file (and the file's last
// chunk cut mid-write). recover writes every whole chunk's rows into the index in their order, those
// read back before the cut once, says what it did, and removes the file only after; a recover run
// again on the same file (cut between its commit and the removal) writes nothing twice.
TEST(IndexOverflow, RecoverWritesTheWaitingRowsIntoTheIndexOnce) {
  const TempDir scratch{overflow_dir("recover")};
  const fs::path& dir = scratch.path;
  const fs::path file = dir / "spill" / kIndexOverflowFile;
  std::int64_t cam = 0;
  {
    SessionIndex index = SessionIndex::create(dir / "session.db");
    index.add_session({1, 2, "test", "rig", "rig.yaml", "name: rig", true});
    cam = index.add_device({"camera", "cam0", "", "", "", "", "", "{}"});
  }
  const auto row = [&](std::uint64_t i) { return unkept_frame(i, cam); };
  std::uint64_t in_file = 0;
  {
    IndexOverflow overflow(file, 50);
    for (std::uint64_t i = 0; i < 5000; ++i) overflow.add(row(i));
    for (int i = 0; i < 500 && overflow.spilled() < 4000; ++i) std::this_thread::sleep_for(10ms);
    ASSERT_GE(overflow.spilled(), 4000u);
  }  // cut: nothing taken back, the file stays as the crash leaves it
  ASSERT_TRUE(fs::exists(file));
  {
    // What the file holds (the spill thread may write more between a count and the cut: under a
    // suite's load 4,096 counted, 4,975 in the file).
    auto chunks = read_record_file(file);
    ASSERT_TRUE(chunks) << chunks.error().message;
    in_file = chunks.value().records.size();
    ASSERT_GE(in_file, 4000u);
  }
  { std::ofstream(file, std::ios::app | std::ios::binary) << std::string("PVIX\x40\x00\x00\x00", 8) << "half a chunk"; }
  {
    // The first 1000 rows had been read back into the index before the cut.
    SessionIndex index = SessionIndex::open_for_update(dir / "session.db");
    sqlite::Transaction tx(index.db());
    for (std::uint64_t i = 0; i < 1000; ++i) index.add(row(i));
    tx.commit();
  }
  const fs::path copy = dir / "overflow.copy";
  fs::copy_file(file, copy);
  auto r = recover_session(dir);
  ASSERT_TRUE(r) << r.error().message;
  std::string said;
  for (const auto& d : r.value().done) said += d + "\n";
  EXPECT_NE(said.find(fmt::format("{} index rows not yet committed when the recording was cut written into "
                                  "the index from index-rows.overflow (1000 it held already)",
                                  in_file - 1000)),
            std::string::npos)
      << said;
  EXPECT_NE(said.find("the last 20 bytes were not a whole chunk"), std::string::npos) << said;
  EXPECT_FALSE(fs::exists(file)) << "removed once its rows are committed";
  const std::string after_first = frames_table(dir / "session.db");
  {
    sqlite::Database db(dir / "session.db", sqlite::Database::Mode::ReadOnly);
    auto q = db.prepare("SELECT sequence FROM frames ORDER BY rowid");
    std::uint64_t expect = 0;
    while (q.step()) ASSERT_EQ(std::uint64_t(q.column_int(0)), expect++);
    EXPECT_EQ(expect, in_file) << "every waiting row once, in its order";
  }
  fs::create_directories(file.parent_path());  // as if the first recover was cut before it removed the file
  fs::copy_file(copy, file);
  auto again = recover_session(dir);
  ASSERT_TRUE(again) << again.error().message;
  said.clear();
  for (const auto& d : again.value().done) said += d + "\n";
  EXPECT_NE(said.find(fmt::format("0 index rows not yet committed when the recording was cut written into the "
                                  "index from index-rows.overflow ({} it held already)",
                                  in_file)),
            std::string::npos)
      << said;
  EXPECT_EQ(frames_table(dir / "session.db"), after_first) << "recover twice: the same rows";
}

// Every kind of record is found by its key once written, and not before: what makes a replay idempotent.
TEST(SessionIndex, EveryKindOfRecordIsHeldOnceWritten) {
  const TempDir scratch{overflow_dir("holds")};
  SessionIndex index = SessionIndex::create(scratch.path / "session.db");
  index.add_session({1, 2, "test", "rig", "rig.yaml", "name: rig", true});
  for (int d = 1; d <= 9; ++d) index.add_device({"camera", fmt::format("cam{}", d), "", "", "", "", "", "{}"});
  std::vector<IndexRecord> records = one_of_each();
  // Referenced rows first: the video file before the frame in it, the frames before the sample.
  std::stable_partition(records.begin(), records.end(),
                        [](const IndexRecord& r) { return std::holds_alternative<VideoFileRecord>(r); });
  std::get<FrameRecord>(records[1]).video_file_id = 5;
  for (const auto& r : records) {
    SCOPED_TRACE("kind " + std::to_string(r.index()));
    if (!std::holds_alternative<VideoFileClosed>(r)) {
      EXPECT_FALSE(index.holds(r));
    }
    index.add(r);
    EXPECT_TRUE(index.holds(r));
  }
}

namespace {
// Every frame row in a session's journal files, by sequence, in file order.
std::vector<std::uint64_t> journal_sequences(const fs::path& spill) {
  std::vector<std::uint64_t> out;
  for (const fs::path& f : index_journal_files(spill)) {
    auto rows = read_record_file(f);
    EXPECT_TRUE(rows) << rows.error().message;
    if (!rows) continue;
    EXPECT_EQ(rows.value().unreadable_bytes, 0u) << f;
    for (const auto& r : rows.value().records) out.push_back(std::get<FrameRecord>(r).sequence);
  }
  return out;
}
}  // namespace

// The journal holds every row appended and not yet committed, in order, across its files; a file
// whose rows are all committed is removed while it records; a clean stop removes them all.
TEST(IndexJournal, EveryRowNotYetCommittedIsInItsFilesAndCommittedFilesGo) {
  const TempDir scratch{overflow_dir("journal")};
  const fs::path spill = scratch.path / "spill";
  {
    IndexJournal journal(spill, 30ms);
    for (std::uint64_t i = 0; i < 3000; ++i) {
      journal.append(frame(i));
      if (i % 100 == 99) std::this_thread::sleep_for(10ms);  // ~10 files of 30 ms
      if (i == 1999) journal.committed(2000);
    }
    std::this_thread::sleep_for(300ms);
    EXPECT_FALSE(journal.failure());
    EXPECT_EQ(journal.rows_appended(), 3000u);
  }  // cut: the destructor keeps what is not committed, as a crash leaves it
  const auto rows = journal_sequences(spill);
  ASSERT_FALSE(rows.empty());
  for (std::size_t i = 1; i < rows.size(); ++i) ASSERT_EQ(rows[i], rows[i - 1] + 1) << "in order, none missing";
  EXPECT_EQ(rows.back(), 2999u) << "the last row appended is there";
  EXPECT_LE(rows.front(), 2000u) << "every row not committed is there";
  EXPECT_GT(rows.front(), 0u) << "files of committed rows were removed";

  {
    IndexJournal journal(spill / "clean");
    for (std::uint64_t i = 0; i < 100; ++i) journal.append(frame(i));
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(journal_sequences(spill / "clean").size(), 100u) << "on disk within a moment";
    journal.stop(/*remove_files=*/true);
    EXPECT_TRUE(index_journal_files(spill / "clean").empty());
  }
}

// The index stalls while rows come: each row is in the journal within a moment, so a copy of the
// session taken then (what a kill -9 leaves) recovers to every row, none twice; the writer's clean
// stop leaves no journal file.
TEST(IndexWriter, RowsWaitingForAStalledIndexAreInTheJournalAndRecoverWritesThem) {
  const TempDir scratch{overflow_dir("journal-stall")};
  const fs::path dir = scratch.path / "session", cut = scratch.path / "cut";
  fs::create_directories(dir);
  std::int64_t cam = 0;
  {
    SessionIndex index = SessionIndex::create(dir / "session.db");
    index.add_session({1, 2, "test", "rig", "rig.yaml", "name: rig", true});
    cam = index.add_device({"camera", "cam0", "", "", "", "", "", "{}"});
    IndexWriter writer(index, IndexWriter::kQueueRecords, 50ms, Stall{1.5, 0.3}, dir / "spill" / kIndexOverflowFile,
                       IndexOverflow::kMemoryRecords, dir / "spill");
    writer.start();
    for (std::uint64_t i = 0; i < 1000; ++i) writer.push(unkept_frame(i, cam));
    std::this_thread::sleep_for(600ms);  // committed; then the index stalls
    for (std::uint64_t i = 1000; i < 6000; ++i) writer.push(unkept_frame(i, cam));
    std::this_thread::sleep_for(500ms);  // still stalled: the rows wait in memory, and in the journal
    EXPECT_EQ(writer.records_written(), 1000u) << "the stall began after the first rows were committed";
    fs::create_directories(cut);
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      if (e.path().filename() == "session.db-shm") continue;
      const fs::path to = cut / fs::relative(e.path(), dir);
      if (e.is_directory())
        fs::create_directories(to);
      else
        fs::copy_file(e.path(), to);
    }
    writer.stop();
    EXPECT_EQ(writer.records_lost(), 0u);
  }
  EXPECT_TRUE(index_journal_files(dir / "spill").empty()) << "a clean stop removes the journal";
  const auto in_journal = journal_sequences(cut / "spill");
  ASSERT_FALSE(in_journal.empty());
  EXPECT_EQ(in_journal.back(), 5999u);
  auto r = recover_session(cut);
  ASSERT_TRUE(r) << r.error().message;
  std::string said;
  for (const auto& d : r.value().done) said += d + "\n";
  EXPECT_NE(said.find("5000 index rows not yet committed when the recording was cut written into the index"),
            std::string::npos)
      << said;
  EXPECT_TRUE(index_journal_files(cut / "spill").empty()) << "removed once its rows are committed";
  sqlite::Database db(cut / "session.db", sqlite::Database::Mode::ReadOnly);
  auto q = db.prepare("SELECT sequence FROM frames ORDER BY rowid");
  std::uint64_t expect = 0;
  while (q.step()) ASSERT_EQ(std::uint64_t(q.column_int(0)), expect++);
  EXPECT_EQ(expect, 6000u) << "every row once, in order";
}
