#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <thread>

#include "core/time.h"
#include "storage/writer/frame_spill.h"
#include "tests/unit/temp_dir.h"

namespace fs = std::filesystem;
using namespace pvcap;
using namespace std::chrono_literals;

namespace {
// Removed when the test ends, also when an assertion ends it early (a failed run left one under /tmp).
pvcap::testing::TempDir spill_dir(const std::string& name) { return {pvcap::testing::fresh_temp_dir("spill", name)}; }

cv::Mat image_of(std::uint64_t i) {
  cv::Mat m(6, 8, CV_8UC1);
  cv::randu(m, 0, 256);
  m.at<std::uint8_t>(0, 0) = std::uint8_t(i);
  return m;
}

FrameRecord row_of(std::uint64_t i) {
  FrameRecord r;
  r.device_id = 3;
  r.connection = 1;
  r.sequence = i;
  r.frame_id = i + 100;
  r.device_ns = std::int64_t(i) * 1000;
  r.host_ns = std::int64_t(i) * 2000;
  r.aravis_system_ns = 5;
  r.status = "good";
  if (i % 2) r.mapped_ns = std::int64_t(i) * 3000;
  if (i % 3) {  // a camera with chunk data: its frames' own state goes through the spill with them
    r.chunk_frame_counter = std::int64_t(i) + 100;
    r.chunk_timestamp = std::int64_t(i) * 1000;
    r.chunk_exposure_us = 4000.25;
  }
  if (i % 3 == 1) r.chunk_gain = 1.5;
  if (i % 4 == 1) r.chunk_line_status = std::int64_t(i % 16);
  return r;
}

std::size_t spill_files(const fs::path& dir) {
  std::size_t n = 0;
  if (fs::is_directory(dir / kSpillFolder))
    for (const auto& e : fs::directory_iterator(dir / kSpillFolder)) n += e.path().extension() == ".spill";
  return n;
}
}  // namespace

// An encoder that is behind: the frames beyond the memory queue go through the disk, and all come
// back in order, pixels and rows intact; once caught up, frames stay in memory again.
TEST(FrameSpill, FramesBeyondMemoryGoThroughTheDiskAndComeBackInOrder) {
  const pvcap::testing::TempDir scratch = spill_dir("order");
  const fs::path& dir = scratch.path;
  std::vector<cv::Mat> images;
  {
    FrameSpillQueue q(dir, "cam0", /*memory_frames=*/4, /*writer_frames=*/64);
    for (std::uint64_t i = 0; i < 30; ++i) {
      images.push_back(image_of(i));
      ASSERT_TRUE(q.push(images.back().clone(), row_of(i))) << i;
    }
    // The four frames waiting in memory when the spill began went to the disk first, in order.
    EXPECT_EQ(q.spilled_total(), 30u);
    EXPECT_EQ(q.backlog(), 30u);
    for (std::uint64_t i = 0; i < 30; ++i) {
      auto item = q.pop_for(2s);
      ASSERT_TRUE(item) << i;
      EXPECT_EQ(item->rec.sequence, i);
      EXPECT_TRUE(item->from_spill) << i;
      EXPECT_EQ(cv::norm(item->image, images[i], cv::NORM_INF), 0.0) << i;
      const FrameRecord want = row_of(i);
      EXPECT_EQ(item->rec.frame_id, want.frame_id);
      EXPECT_EQ(item->rec.device_ns, want.device_ns);
      EXPECT_EQ(item->rec.host_ns, want.host_ns);
      EXPECT_EQ(item->rec.mapped_ns, want.mapped_ns);
      EXPECT_EQ(item->rec.status, "good");
      EXPECT_EQ(item->rec.chunk_frame_counter, want.chunk_frame_counter) << i;
      EXPECT_EQ(item->rec.chunk_timestamp, want.chunk_timestamp) << i;
      EXPECT_EQ(item->rec.chunk_exposure_us, want.chunk_exposure_us) << i;
      EXPECT_EQ(item->rec.chunk_gain, want.chunk_gain) << i;
      EXPECT_EQ(item->rec.chunk_line_status, want.chunk_line_status) << i;
    }
    EXPECT_EQ(q.backlog(), 0u);
    // Caught up: the episode's file waits for its segment to be finished, then goes.
    EXPECT_EQ(spill_files(dir), 1u);
    q.release_finished();
    EXPECT_EQ(spill_files(dir), 0u);
    // And the next frame is a memory frame again.
    ASSERT_TRUE(q.push(image_of(30), row_of(30)));
    auto item = q.pop_for(1s);
    ASSERT_TRUE(item);
    EXPECT_FALSE(item->from_spill);
    q.close();
    EXPECT_FALSE(q.pop_for(10ms));
    EXPECT_TRUE(q.drained());
  }
}

// Pushes and pops from two threads at once, the encoder slower than the camera for a while: nothing
// lost, nothing reordered.
TEST(FrameSpill, ACameraFasterThanItsEncoderLosesNothing) {
  const pvcap::testing::TempDir scratch = spill_dir("race");
  const fs::path& dir = scratch.path;
  {
    // The writer's queue is large enough that a stalled writer thread on a loaded machine refuses
    // nothing: this test is about order and completeness across threads, not the disk's speed.
    FrameSpillQueue q(dir, "cam1", 3, 400);
    std::uint64_t pushed = 0, refused = 0;
    std::thread camera([&] {
      for (std::uint64_t i = 0; i < 400; ++i) {
        if (q.push(image_of(i), row_of(i)))
          ++pushed;
        else
          ++refused;
        std::this_thread::sleep_for(200us);
      }
      q.close();
    });
    std::uint64_t expected = 0, from_spill = 0;
    while (auto item = q.pop_for(2s)) {
      EXPECT_EQ(item->rec.sequence, expected);
      expected = item->rec.sequence + 1;
      from_spill += item->from_spill;
      if (item->rec.sequence < 200) std::this_thread::sleep_for(1ms);  // behind, then catching up
    }
    camera.join();
    EXPECT_EQ(refused, 0u);
    EXPECT_EQ(expected, 400u);
    EXPECT_GT(from_spill, 0u);
    EXPECT_TRUE(q.drained());
  }
}

// A frame waits in memory at most the queue's age limit: when the encoder is held up longer, the
// frames in memory go to the disk (where a power cut cannot take them), ahead of the new one.
TEST(FrameSpill, FramesHeldInMemoryTooLongGoToTheDisk) {
  const pvcap::testing::TempDir scratch = spill_dir("age");
  const fs::path& dir = scratch.path;
  {
    FrameSpillQueue q(dir, "cam5", /*memory_frames=*/8, /*writer_frames=*/8, /*memory_age=*/50ms);
    ASSERT_TRUE(q.push(image_of(0), row_of(0)));
    ASSERT_TRUE(q.push(image_of(1), row_of(1)));
    EXPECT_EQ(q.spilled_total(), 0u) << "young frames stay in memory";
    std::this_thread::sleep_for(80ms);
    ASSERT_TRUE(q.push(image_of(2), row_of(2)));
    EXPECT_EQ(q.spilled_total(), 3u);
    EXPECT_EQ(q.on_disk(), 3u);
    for (int i = 0; i < 200 && spill_files(dir) == 0; ++i) std::this_thread::sleep_for(5ms);
    EXPECT_EQ(spill_files(dir), 1u);
    for (std::uint64_t i = 0; i < 3; ++i) {
      auto item = q.pop_for(1s);
      ASSERT_TRUE(item) << i;
      EXPECT_EQ(item->rec.sequence, i);
      EXPECT_TRUE(item->from_spill) << i;
    }
    // Caught up: memory again.
    ASSERT_TRUE(q.push(image_of(3), row_of(3)));
    auto item = q.pop_for(1s);
    ASSERT_TRUE(item);
    EXPECT_FALSE(item->from_spill);
    q.close();
  }
}

// The frame in the encoder's hands is in memory too: an encoder held up with it (a slow first
// frame, a stalled disk) past the age limit, with no new frame coming, sends it and the others to
// the disk; once written, its spilled copy is not handed out again, and how long it took is kept.
TEST(FrameSpill, TheFrameInTheEncodersHandsGoesToTheDiskWhenItIsHeldUp) {
  const pvcap::testing::TempDir scratch = spill_dir("in-hand");
  const fs::path& dir = scratch.path;
  {
    FrameSpillQueue q(dir, "cam6", /*memory_frames=*/8, /*writer_frames=*/8, /*memory_age=*/50ms);
    FrameRecord first = row_of(0), second = row_of(1);
    first.host_ns = pvcap::host_now().ns;
    second.host_ns = first.host_ns + 1;
    ASSERT_TRUE(q.push(image_of(0), first));
    ASSERT_TRUE(q.push(image_of(1), second));
    auto in_hand = q.pop_for(1s);
    ASSERT_TRUE(in_hand);
    EXPECT_FALSE(in_hand->from_spill);
    // Held up: no push comes, the spill's writer finds them too old on its own.
    // (on_disk() counts them once handed to the writer; the age is noted once one is appended.)
    for (int i = 0; i < 200 && (q.on_disk() < 2 || q.worst_disk_age().worst_ns == 0); ++i)
      std::this_thread::sleep_for(5ms);
    EXPECT_EQ(q.on_disk(), 2u) << "both frames, the one in hand too, went to the disk";
    EXPECT_EQ(q.spilled_total(), 2u);
    EXPECT_TRUE(q.worst_disk_age().via_spill);
    EXPECT_GE(q.worst_disk_age().worst_ns, 50'000'000);
    q.written(*in_hand);
    auto next = q.pop_for(1s);
    ASSERT_TRUE(next);
    EXPECT_EQ(next->rec.sequence, 1u) << "the written frame's spilled copy is skipped";
    EXPECT_TRUE(next->from_spill);
    q.close();
    EXPECT_FALSE(q.pop_for(100ms));
    EXPECT_TRUE(q.drained());
  }
}

// Memory stays bounded when the disk is slower than the camera: with the writer's queue full, a
// frame is refused (the caller records it as lost) instead of piling up.
TEST(FrameSpill, AWriterThatCannotKeepUpRefusesInsteadOfGrowing) {
  const pvcap::testing::TempDir scratch = spill_dir("bound");
  const fs::path& dir = scratch.path;
  {
    FrameSpillQueue q(dir, "cam4", 2, 0);  // no room for the writer: every frame past memory is refused
    EXPECT_TRUE(q.push(image_of(0), row_of(0)));
    EXPECT_TRUE(q.push(image_of(1), row_of(1)));
    EXPECT_FALSE(q.push(image_of(2), row_of(2)));
    EXPECT_EQ(q.backlog(), 2u);
    EXPECT_EQ(q.spilled_total(), 0u);
    q.close();
    EXPECT_FALSE(q.push(image_of(3), row_of(3))) << "a closed queue takes nothing";
    EXPECT_EQ(q.pop_for(1s)->rec.sequence, 0u);
    EXPECT_EQ(q.pop_for(1s)->rec.sequence, 1u);
    EXPECT_FALSE(q.pop_for(10ms));
    EXPECT_TRUE(q.drained());
  }
}

// A spill cut by a crash reads up to its last whole record; a foreign file is named as such.
TEST(FrameSpill, ACutSpillReadsToItsLastWholeRecord) {
  const pvcap::testing::TempDir scratch = spill_dir("cut");
  const fs::path& dir = scratch.path;
  {
    FrameSpillQueue q(dir, "cam2", 0, 64);  // no memory: every frame goes to the disk
    for (std::uint64_t i = 0; i < 5; ++i) ASSERT_TRUE(q.push(image_of(i), row_of(i)));
  }  // destroyed without reading (its writer finishes first): what it holds stays, as after a crash
  ASSERT_EQ(spill_files(dir), 1u);
  const fs::path file = fs::directory_iterator(dir / kSpillFolder)->path();
  const auto size = fs::file_size(file);
  fs::resize_file(file, size - 10);  // the last record cut
  std::vector<std::uint64_t> seen;
  auto n = read_spill_file(file, [&](SpillRecord&& r) {
    seen.push_back(r.rec.sequence);
    EXPECT_EQ(r.image.at<std::uint8_t>(0, 0), std::uint8_t(r.rec.sequence));
  });
  ASSERT_TRUE(n) << n.error().message;
  EXPECT_EQ(n.value(), 4u);
  EXPECT_EQ(seen, (std::vector<std::uint64_t>{0, 1, 2, 3}));
  // A flipped byte in a record's pixels ends the reading there (its CRC), never a wrong frame.
  {
    std::FILE* f = std::fopen(file.c_str(), "r+b");
    std::fseek(f, long(size / 2), SEEK_SET);
    const int c = std::fgetc(f);
    std::fseek(f, long(size / 2), SEEK_SET);
    std::fputc(c ^ 0xff, f);
    std::fclose(f);
  }
  auto damaged = read_spill_file(file, [](SpillRecord&&) {});
  ASSERT_TRUE(damaged);
  EXPECT_LT(damaged.value(), 4u);
  const fs::path foreign = dir / "foreign.spill";
  std::FILE* f = std::fopen(foreign.c_str(), "wb");
  std::fputs("not a spill file at all, but long enough", f);
  std::fclose(f);
  auto refused = read_spill_file(foreign, [](SpillRecord&&) {});
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("not a pvcap spill file"), std::string::npos);
}

// After the disk refused one of the session's writes (the shared halt): the spill's writer appends
// nothing more and hands its frames back as storage_failed; abandon() hands back the rest and what
// the spill already holds stays in its file for recover.
TEST(FrameSpill, AfterAFailedWriteNothingMoreIsWrittenAndTheSpillStaysForRecover) {
  const pvcap::testing::TempDir scratch = spill_dir("halt");
  const fs::path& dir = scratch.path;
  const auto halt = std::make_shared<std::atomic<bool>>(false);
  fs::path file;
  {
    FrameSpillQueue q(dir, "cam7", /*memory_frames=*/2, /*writer_frames=*/64);
    q.share_halt(halt);
    for (std::uint64_t i = 0; i < 5; ++i) ASSERT_TRUE(q.push(image_of(i), row_of(i)));
    const auto on_disk_by = std::chrono::steady_clock::now() + 5s;
    while (q.on_disk() != 5 || spill_files(dir) != 1) {
      ASSERT_LT(std::chrono::steady_clock::now(), on_disk_by) << "the five frames never reached the spill";
      std::this_thread::sleep_for(5ms);
    }
    file = fs::directory_iterator(dir / kSpillFolder)->path();
    const auto size_before = fs::file_size(file);
    halt->store(true);  // e.g. another camera's video met a full disk
    ASSERT_TRUE(q.push(image_of(5), row_of(5)));
    ASSERT_TRUE(q.push(image_of(6), row_of(6)));
    const auto handed_back_by = std::chrono::steady_clock::now() + 5s;
    while (q.on_disk() != 5) {  // the two are taken by the writer and not written
      ASSERT_LT(std::chrono::steady_clock::now(), handed_back_by) << "the writer never took the two frames";
      std::this_thread::sleep_for(5ms);
    }
    EXPECT_EQ(fs::file_size(file), size_before) << "nothing is appended after the halt";
    auto lost = q.abandon();
    ASSERT_EQ(lost.size(), 2u);
    for (std::size_t k = 0; k < 2; ++k) {
      EXPECT_EQ(lost[k].rec.sequence, 5 + k);
      EXPECT_EQ(lost[k].lost_reason, "storage_failed");
      EXPECT_TRUE(lost[k].image.empty()) << "its pixels are not kept";
    }
    EXPECT_TRUE(q.drained());
    EXPECT_FALSE(q.push(image_of(7), row_of(7))) << "an abandoned queue takes nothing";
  }
  std::vector<std::uint64_t> kept;
  auto n = read_spill_file(file, [&](SpillRecord&& r) { kept.push_back(r.rec.sequence); });
  ASSERT_TRUE(n) << n.error().message;
  EXPECT_EQ(kept, (std::vector<std::uint64_t>{0, 1, 2, 3, 4})) << "the spill keeps what it held, for recover";
}

// The spill's writer behind the camera (here: busy with one 256-MB frame, its CRC and its write,
// far longer than the 20 ms allowed): the frames that would wait for it longer are refused instead
// of queued, so that what a power cut can take is bounded in time; once it has caught up, frames are
// taken again, and every frame taken comes back in order.
TEST(FrameSpill, AFrameThatWouldWaitForTheWriterTooLongIsRefused) {
  const pvcap::testing::TempDir scratch = spill_dir("writer-age");
  const fs::path& dir = scratch.path;
  {
    FrameSpillQueue q(dir, "cam8", /*memory_frames=*/0, /*writer_frames=*/64, /*memory_age=*/200ms,
                      /*writer_age=*/20ms);
    cv::Mat big(16384, 16384, CV_8UC1, cv::Scalar(7));
    ASSERT_TRUE(q.push(big, row_of(0)));
    big.release();
    std::vector<std::uint64_t> taken{0};
    std::size_t refused = 0;
    for (std::uint64_t i = 1; i <= 10; ++i) {
      std::this_thread::sleep_for(5ms);
      if (q.push(image_of(i), row_of(i)))
        taken.push_back(i);
      else
        ++refused;
    }
    EXPECT_GE(refused, 3u) << "frames pushed 30-50 ms after the first waited too long for the busy writer";
    const auto caught_up_by = std::chrono::steady_clock::now() + 20s;
    while (!taken.empty() && std::chrono::steady_clock::now() < caught_up_by) {
      auto item = q.pop_for(100ms);
      if (!item) continue;
      EXPECT_EQ(item->rec.sequence, taken.front());
      taken.erase(taken.begin());
      q.written(*item);
    }
    EXPECT_TRUE(taken.empty()) << taken.size() << " frames taken never came back";
    EXPECT_TRUE(q.push(image_of(11), row_of(11))) << "caught up: frames are taken again";
  }
}

// A read the disk fails is said as the disk's error, never taken for a crash's cut tail (which
// recover would pass over in silence): here a folder, whose pread fails with EISDIR.
TEST(FrameSpill, AReadTheDiskFailsIsAnErrorNotACutTail) {
  const pvcap::testing::TempDir scratch = spill_dir("unreadable");
  const fs::path& dir = scratch.path;
  const auto read = read_spill_file(dir, [](SpillRecord&&) {});
  ASSERT_FALSE(read);
  EXPECT_NE(read.error().message.find("cannot be read: Is a directory"), std::string::npos) << read.error().message;
}

// A spill an older pvcap left (records "PVS3": chunk data without line levels) reads as it was
// written, beside the current layout ("PVS4"), both kept in the spill reader's fuzz seeds.
TEST(FrameSpill, AnOlderPvcapsSpillReadsInItsOwnLayout) {
  const fs::path seeds = fs::path(PVCAP_SOURCE_DIR) / "tests/fuzz/seeds_spill_reader";
  for (const char* name : {"whole-with-chunks.spill", "whole-with-line-levels.spill"}) {
    SCOPED_TRACE(name);
    const bool with_lines = std::string(name) == "whole-with-line-levels.spill";
    std::vector<SpillRecord> records;
    auto n = read_spill_file(seeds / name, [&](SpillRecord&& r) { records.push_back(std::move(r)); });
    ASSERT_TRUE(n) << n.error().message;
    ASSERT_EQ(records.size(), 3u);
    for (const SpillRecord& r : records) {
      EXPECT_EQ(r.rec.status, "good");
      EXPECT_TRUE(r.rec.chunk_exposure_us);
      EXPECT_FALSE(r.image.empty());
      EXPECT_EQ(r.rec.chunk_line_status, with_lines ? std::optional<std::int64_t>(2) : std::nullopt);
    }
  }
}
