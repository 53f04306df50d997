#pragma once
// `pvcap recover SESSION`: makes a session interrupted by a crash, kill or power cut
// readable. SQLite replays its write-ahead log on open; each video segment that was
// still open is copied, up to its last complete frame that the index names, into a
// finished file (the cut original is kept beside it as *.interrupted.mkv); index rows
// of frames that never reached the disk are marked (kept = 0, reason
// lost_at_interruption), never deleted; the session gets an end. Running it twice
// changes nothing the second time. An older store is upgraded first (after a backup).
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "core/result.h"

namespace pvcap {

struct RecoverReport {
  std::vector<std::string> done;  // what was changed, in order
  bool was_interrupted = false;
};

Result<RecoverReport> recover_session(const std::filesystem::path& dir,
                                      const std::function<void(const std::string&)>& progress = nullptr);

// `pvcap migrate SESSION`: upgrades an older store's index in place (after a backup copy).
Result<std::vector<std::string>> migrate_session(const std::filesystem::path& dir,
                                                 const std::function<void(const std::string&)>& progress = nullptr);

}  // namespace pvcap
