#pragma once
// PTP time around a session (rig file `ptp:`; docs/multihost.md): the cameras locked before it starts,
// and the host's PTP time while it records (rig file `ptp:`; docs/multihost.md): ptp4l's state
// read through pmc once a second on a thread of its own, each reading stored as an event
// (`ptp_host_state`, its fields as JSON), and each second the host is out of time, or ptp4l does
// not answer, named by an event of its own (`ptp_host_out_of_time`) and, when it begins and ends, in
// the log. A reading costs ~10 ms of a helper process; a pmc that hangs costs this thread one second,
// never a capture thread.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/result.h"
#include "core/rig_config.h"
#include "storage/index/records.h"
#include "sync/ptp_host.h"

namespace pvcap {
class AravisCamera;
}

namespace pvcap::session {

// What the watch saw over the session, for its closing lines.
struct PtpHostTally {
  int readings = 0;              // answers from ptp4l
  int seconds_out_of_time = 0;   // readings out of time, and seconds without an answer
  double worst_offset_ns = 0;    // the largest |offset from master| read
  std::string grandmaster;       // the last one followed
  std::string last_problem;      // the last reason it was out of time
};

// Before a session: the host's state, or an Error saying why the host is not in time and what to do.
Result<sync::PtpHostState> check_ptp_host(const PtpRigConfig& config);

// Before a session, the cameras opened (their PTP enabled): waits up to config.lock_wait_s for every
// camera to lock, reading each four times a second; an Error naming each camera not locked by then,
// its state, and what to check.
Status wait_for_ptp_lock(const std::vector<std::unique_ptr<AravisCamera>>& cameras, const PtpRigConfig& config,
                         const std::atomic<bool>& cancel);

class PtpHostWatch {
 public:
  using Sink = std::function<void(const EventRecord&)>;
  // Reads at once, then every `period`; `sink` stores each event (called on the watch's thread).
  PtpHostWatch(const PtpRigConfig& config, Sink sink, std::chrono::milliseconds period = std::chrono::seconds(1));
  ~PtpHostWatch();  // stops the thread
  PtpHostWatch(const PtpHostWatch&) = delete;
  PtpHostWatch& operator=(const PtpHostWatch&) = delete;

  PtpHostTally tally() const;

 private:
  void run();
  void read_once();
  sync::PmcClient pmc_;
  double max_offset_ns_;
  Sink sink_;
  std::chrono::milliseconds period_;
  mutable std::mutex mu_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool out_of_time_ = false;
  PtpHostTally tally_;
  std::thread thread_;
};

}  // namespace pvcap::session
