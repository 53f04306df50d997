#pragma once
// A sequence's JPEGs, written by lanes: one per core, each with a SessionReader of its own (a reader
// is one thread's). Lane l decodes, crops, encodes, writes and hashes cameras l, l + L, ... sample
// after sample, so every core stays busy (decoding on one thread while others encoded left a core
// waiting: 1.9x the JPEG encoder alone, docs/performance-log.md). The caller follows the lanes sample by
// sample (wait_past) to write what goes with each sample and to show progress.
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.h"
#include "storage/index/session_reader.h"

namespace pvcap::exporting {

// Name in the sequence -> bytes and SHA-256 of what a run wrote, taken from memory.
using FileSums = std::map<std::string, std::pair<std::size_t, std::string>>;

class JpegLanes {
 public:
  struct Settings {
    std::vector<std::size_t> cameras;  // the session's camera index of each exported camera
    std::vector<cv::Rect> crops;       // with `crop`: each exported camera's box
    bool crop = false;
    int quality = 95;
  };
  // Opens one reader per lane (as many lanes as cores, at most one per camera).
  static Result<std::unique_ptr<JpegLanes>> open(const std::filesystem::path& session, Settings settings);
  ~JpegLanes();

  // Starts writing samples[t]'s frame of exported camera k as dir/camera_<k>/<t, 5 digits>.jpg, each
  // that is not there yet. A true `stop` ends the lanes at their next frame.
  void start(const std::vector<std::size_t>& samples, const std::filesystem::path& dir, const std::atomic<bool>& stop);
  // Waits until every lane has passed sample t (or ended); false once a lane has failed.
  bool wait_past(std::size_t t);
  bool wrote(std::size_t t) const;  // a JPEG of sample t written by this run
  // Ends the lanes (at their next frame when `abandon`) and joins them: the first lane's error,
  // or the written files' sums added to `sums`.
  Status finish(bool abandon, FileSums& sums);

 private:
  struct Lane {
    std::vector<std::size_t> cameras;  // indices into Settings::cameras
    std::vector<std::pair<std::string, std::pair<std::size_t, std::string>>> sums;
    std::vector<std::uint8_t> wrote;  // per sample
    std::vector<std::uint8_t> jpeg;   // the lane's JPEG buffer, reused picture after picture
    Status status;
    std::size_t finished = 0;  // samples done (under mu_)
  };
  JpegLanes(Settings settings, std::vector<std::unique_ptr<SessionReader>> readers);
  void run(std::size_t l, const std::vector<std::size_t>& samples, const std::filesystem::path& dir,
           const std::atomic<bool>& stop);
  Status write_one(SessionReader& reader, std::size_t sample, std::size_t k, const std::filesystem::path& dir,
                   const std::filesystem::path& jpg, Lane& lane);

  const Settings settings_;
  std::vector<std::unique_ptr<SessionReader>> readers_;  // one per lane
  std::vector<Lane> lanes_;
  std::vector<std::thread> threads_;
  std::atomic<bool> failed_{false}, abandoned_{false};
  std::mutex mu_;
  std::condition_variable cv_;
};

}  // namespace pvcap::exporting
