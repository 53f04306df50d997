#pragma once
// A camera's kept frames on their way to its encoder, in order, never dropped for being late.
//
// While the encoder keeps up, frames wait in memory (a few). When it falls behind, every further
// frame goes to a spill file on disk (append-only, in the session folder) until the encoder has
// read the spill back to its end; then memory again. Order is kept throughout: memory frames are
// always older than spilled ones, so the video's timestamps only grow. Memory stays bounded (the
// memory queue plus a few frames waiting for the spill's writer thread); only a disk that cannot
// take the frames loses them, and then each with its reason.
//
// The spill's writer may be held up (a busy core, the page cache throttling writes): it takes up to
// `writer_frames` frames behind (32 by default, a second of a 30 Hz camera: 64 MB of 1080p 8-bit
// mosaics, 200 MB of BGR) before a frame is refused. 8 was too few: under a test suite's load a
// writer fell 270 ms behind and 15 frames were lost.
//
// Memory is the one place a frame can be lost to a power cut: so a frame waits there at most
// `memory_age` (200 ms by default), the one in the encoder's hands included. When the oldest is
// older (the encoder is held up, even mid-frame), every frame in memory goes to the disk too, in
// order, and from there to the encoder; with the store's sync round (docs/store.md) what a power cut
// loses stays within a second even while an encoder is stalled. The spill's writer looks every 50 ms,
// so the rule holds when no new frame comes (the end of a session).
//
// Crash safety: a spill record is written with its index row (FrameRecord) and a CRC, so a file
// cut by a crash reads up to its last whole record; `pvcap recover` encodes whatever a spill holds
// that no video does (storage/writer/recover.cpp). A spill file read back to its end is deleted only once
// the video segment holding its frames is finished (release_finished()), so a crash in between
// still finds them.
#include <atomic>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.h"
#include "storage/index/session_index.h"

namespace pvcap {

struct SpillItem {
  cv::Mat image;
  FrameRecord rec;
  std::string lost_reason;  // set: the frame could not be kept (image empty); record it with this reason
  bool from_spill = false;  // read back from disk
  std::chrono::steady_clock::time_point pushed{};  // when it came (memory's age limit)
};

class FrameSpillQueue {
 public:
  // `dir`: the session folder (spill files go to dir/spill/<camera>-<n>.spill, made on first use).
  static constexpr std::chrono::milliseconds kMemoryAge{200};
  // How long a frame may wait for the spill's writer (since it came): past it the writer is behind
  // the camera (the disk is slower than the frames) and new frames are refused, so that what a power
  // cut can take stays bounded in time (this, one append and store.sync_interval_s: under a second),
  // not in frames: 32 frames of four 1080p cameras waited 3.7 s on a congested disk.
  static constexpr std::chrono::milliseconds kWriterAge{400};
  FrameSpillQueue(std::filesystem::path dir, std::string camera, std::size_t memory_frames,
                  std::size_t writer_frames = 32, std::chrono::milliseconds memory_age = kMemoryAge,
                  std::chrono::milliseconds writer_age = kWriterAge);
  ~FrameSpillQueue();
  FrameSpillQueue(const FrameSpillQueue&) = delete;
  FrameSpillQueue& operator=(const FrameSpillQueue&) = delete;

  // Capture side; never waits on the disk. False only when the spill's writer is itself behind
  // (writer_frames waiting, or the oldest waiting longer than writer_age: the disk is slower than the
  // camera) or the queue is closed: the caller records the frame as lost.
  bool push(cv::Mat image, FrameRecord rec);
  // Encoder side: the next frame in order, waiting up to `timeout`. Empty on timeout, or when
  // closed and everything (memory and disk) has been handed out. A frame from memory stays there
  // until `written` (the age rule may still send it to the spill while the encoder is held up with
  // it in hand); its spilled copy is then skipped.
  std::optional<SpillItem> pop_for(std::chrono::milliseconds timeout);
  // The encoder is done with `item` (written to its video, or recorded as not kept); the next pop
  // says so too, but later (this one also times how long it took to reach the disk).
  void written(const SpillItem& item);
  // No more pushes; pop_for goes on until memory and spill are empty.
  void close();
  bool drained() const;  // closed, and nothing left to hand out (or abandoned)
  // The disk failed a write of the session: nothing more is written, so that the space it has left
  // (the store's reserve) finishes the index. The frames waiting in memory and for the spill's writer
  // are handed back (each with why it is lost); what the spill already holds stays in its file, for
  // recover. From here on push() refuses.
  std::vector<SpillItem> abandon();
  // A flag the session's writers share: set by this queue when the disk refuses its write, and once
  // set (by anyone), its writer appends nothing more (the frames are handed back as storage_failed),
  // so that the space left finishes the index. Given once, right after construction.
  void share_halt(std::shared_ptr<std::atomic<bool>> halt);
  bool is_closed() const;
  // The encoder finished a video segment: spill files read to their end before now can go.
  void release_finished();

  std::size_t backlog() const;                 // frames waiting: in memory, for the writer, and on disk
  std::size_t on_disk() const;                 // of which on disk
  std::uint64_t spilled_total() const;         // frames that went through the disk so far
  std::optional<std::string> failure() const;  // the disk refused a write (the first reason)

  // How long after its arrival a kept frame reached the kernel's files at worst: noted for each
  // frame the spill's writer appends and each memory frame the encoder has written. What a power
  // cut can take is this plus the sync interval (docs/store.md).
  struct DiskAge {
    std::int64_t worst_ns = 0;
    std::int64_t arrived_host_ns = 0;  // that frame's arrival
    bool via_spill = false;            // it reached the disk in the spill (else in its video)
  };
  DiskAge worst_disk_age() const;

 private:
  void writer_loop();
  Status append(const SpillItem& item);
  void memory_to_spill();     // under mu_: every frame in memory to the spill's writer, in order
  void spill_stale_memory();  // under mu_: so, when the oldest has waited longer than memory_age_
  std::optional<SpillItem> read_back_failed(const std::string& why);  // under mu_

  std::filesystem::path folder_;
  std::string camera_;
  std::size_t memory_cap_, writer_cap_;
  std::chrono::milliseconds memory_age_, writer_age_;

  mutable std::mutex mu_;
  std::condition_variable ready_;     // the encoder's: something to pop
  std::condition_variable to_write_;  // the writer's: something to append
  std::deque<SpillItem> memory_, for_writer_, lost_;
  bool writing_ = false;  // the writer holds an item (taken from for_writer_, not yet on disk)
  std::size_t on_disk_ = 0;
  std::uint64_t spilled_ = 0;
  bool closed_ = false, stop_writer_ = false, abandoned_ = false;
  std::shared_ptr<std::atomic<bool>> halt_;  // under mu_
  std::optional<std::string> failure_;
  DiskAge disk_age_;
  std::optional<std::int64_t> in_hand_host_ns_;       // the memory frame with the encoder (by its arrival)
  void done_with(std::int64_t host_ns);               // under mu_: the encoder is done with that frame
  std::int64_t written_through_host_ns_ = INT64_MIN;  // the encoder has written every frame arrived by then

  // The spill file being written and read (opened on the first spill of an episode).
  int fd_ = -1;
  std::filesystem::path file_;
  std::int64_t write_off_ = 0, read_off_ = 0;
  int next_file_ = 1;
  std::vector<std::filesystem::path> finished_files_;  // read to their end; deleted at release_finished
  std::thread writer_;
};

// One record of a spill file as `pvcap recover` reads it.
struct SpillRecord {
  FrameRecord rec;
  cv::Mat image;
};
// Reads every whole record of `file` in order and hands it to `each`; stops at the end or at the
// first record that is cut or damaged (a crash's tail). Returns the records read, or an Error when
// the file cannot be opened or is not a spill file.
Result<std::size_t> read_spill_file(const std::filesystem::path& file, const std::function<void(SpillRecord&&)>& each);

}  // namespace pvcap
