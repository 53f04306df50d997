#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/durable_folder.h"
#include "tests/unit/temp_dir.h"

namespace fs = std::filesystem;
using namespace pvcap;
using namespace std::chrono_literals;

namespace {

using pvcap::testing::TempDir;

TempDir scratch(const std::string& name) { return TempDir{pvcap::testing::fresh_temp_dir("durable", name)}; }

void append(const fs::path& file, std::size_t bytes) {
  std::ofstream(file, std::ios::binary | std::ios::app) << std::string(bytes, 'x');
}

}  // namespace

// A round syncs what changed since the last one, and only that; a file removed is forgotten.
TEST(DurableFolder, ARoundSyncsTheFilesThatChangedAndTheFoldersWhoseEntriesDid) {
  const TempDir dir = scratch("changed");
  append(dir.path / "a.mkv", 100);
  append(dir.path / "b.mkv", 100);
  DurableFolder durable(dir.path, {"spill"});
  ASSERT_TRUE(durable.sync_changed().ok());
  EXPECT_EQ(durable.counts().file_syncs, 2u);
  EXPECT_EQ(durable.counts().folder_syncs, 1u) << "two new names in the session folder";

  ASSERT_TRUE(durable.sync_changed().ok());
  EXPECT_EQ(durable.counts().file_syncs, 2u) << "nothing changed";
  EXPECT_EQ(durable.counts().folder_syncs, 1u);

  append(dir.path / "a.mkv", 10);
  fs::create_directories(dir.path / "spill");
  append(dir.path / "spill" / "cam0-0001.spill", 10);
  ASSERT_TRUE(durable.sync_changed().ok());
  EXPECT_EQ(durable.counts().file_syncs, 4u) << "the grown video and the new spill file";
  EXPECT_EQ(durable.counts().folder_syncs, 3u) << "the spill folder's new entry, the session folder's new subfolder";

  fs::remove(dir.path / "spill" / "cam0-0001.spill");
  const auto folders = durable.counts().folder_syncs;
  ASSERT_TRUE(durable.sync_changed().ok());
  EXPECT_EQ(durable.counts().file_syncs, 4u);
  EXPECT_GT(durable.counts().folder_syncs, folders) << "a removed name is synced too";
  EXPECT_EQ(durable.counts().rounds, 4u);
}

// The gap a round reports is the longest a write could have waited unsynced: from the previous
// round's start (a write just after it listed its file waits for this round) to this round's end.
TEST(DurableFolder, TheGapRunsFromThePreviousRoundsStartToThisOnesEnd) {
  const TempDir dir = scratch("gap");
  append(dir.path / "a.mkv", 1 << 20);
  DurableFolder durable(dir.path, {});
  const auto before = std::chrono::steady_clock::now();
  ASSERT_TRUE(durable.sync_changed().ok());
  const double first_round_ms = durable.counts().last_round_ms;
  std::this_thread::sleep_for(200ms);
  append(dir.path / "a.mkv", 1 << 20);
  ASSERT_TRUE(durable.sync_changed().ok());
  const double outer_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - before).count();
  const auto& c = durable.counts();
  EXPECT_GE(c.last_gap_ms, first_round_ms + 200 + c.last_round_ms - 0.01);
  EXPECT_LE(c.last_gap_ms, outer_ms);
}

// The write-back steps run on a thread of their own beside the rounds (a step can block on a busy
// disk and must never hold a round back): the two share no state, and every round still syncs
// what changed.
TEST(DurableFolder, WriteBackBesideTheRoundsLeavesEveryChangeToARound) {
  const TempDir dir = scratch("writeback");
  fs::create_directories(dir.path / "spill");
  DurableFolder durable(dir.path, {"spill"});
  std::atomic<bool> stop{false};
  std::thread writer([&] {
    for (int i = 0; !stop.load(); ++i) {
      append(dir.path / ("cam" + std::to_string(i % 4) + "-001.mkv"), 4096);
      if (i % 16 == 0) append(dir.path / "spill" / ("cam0-" + std::to_string(i) + ".spill"), 4096);
      if (i % 16 == 8) fs::remove(dir.path / "spill" / ("cam0-" + std::to_string(i - 8) + ".spill"));
    }
  });
  std::thread writeback([&] {
    while (!stop.load()) durable.start_writeback();
  });
  for (int round = 0; round < 50; ++round) {
    ASSERT_TRUE(durable.sync_changed().ok());
    std::this_thread::sleep_for(2ms);
  }
  stop.store(true);
  writer.join();
  writeback.join();
  const auto syncs = durable.counts().file_syncs;
  EXPECT_GT(syncs, 25u);
  // Once the writing stopped, one round takes what is left and the next finds nothing.
  ASSERT_TRUE(durable.sync_changed().ok());
  const auto settled = durable.counts().file_syncs;
  ASSERT_TRUE(durable.sync_changed().ok());
  EXPECT_EQ(durable.counts().file_syncs, settled);
}
