#pragma once
// The host's PTP time as linuxptp's ptp4l holds it, read through ptp4l's management client `pmc`
// over ptp4l's Unix socket (Debian's linuxptp; docs/multihost.md). pvcap never starts, configures or
// steers ptp4l, and never touches the clock: it reads what ptp4l measured (its port's state, the
// grandmaster it follows, its offset from its master) so that a session records the time it was
// recorded on, and refuses to start on a host that is not in time.
//
// One query is one pmc run with four management GETs, bounded in time (a ptp4l that hangs costs the
// caller its limit, never a capture thread: the session polls from a thread of its own).
#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"

namespace pvcap::sync {

struct PtpHostState {
  std::string port_state;      // PORT_DATA_SET portState: SLAVE, MASTER, UNCALIBRATED, LISTENING, FAULTY, ...
  std::string clock_identity;  // this host's PTP clock (its port identity without the port number)
  std::string grandmaster;     // PARENT_DATA_SET grandmasterIdentity
  bool gm_present = false;     // TIME_STATUS_NP gmPresent: a grandmaster is heard
  double offset_ns = 0;        // CURRENT_DATA_SET offsetFromMaster (0 on the grandmaster itself)
  double path_delay_ns = 0;    // CURRENT_DATA_SET meanPathDelay
  int steps_removed = 0;       // CURRENT_DATA_SET stepsRemoved: 0 on the grandmaster
  bool is_grandmaster() const { return !clock_identity.empty() && clock_identity == grandmaster; }
};

// The GETs one query sends, as pmc takes them.
inline constexpr const char* kPmcQueries[] = {"GET CURRENT_DATA_SET", "GET PORT_DATA_SET", "GET TIME_STATUS_NP",
                                              "GET PARENT_DATA_SET"};

// pmc's printed answer to kPmcQueries, parsed; an Error naming the first answer or field missing
// (pmc prints nothing for a GET ptp4l did not answer).
Result<PtpHostState> parse_pmc_answer(std::string_view text);

// Whether the host is in time for a recording: the grandmaster itself, or hearing one with its port
// following it (SLAVE, or UNCALIBRATED when ptp4l only measures: `free_running 1`) within
// `max_offset_ns`. nullopt when it is; otherwise why not, in words an operator can act on.
std::optional<std::string> ptp_host_out_of_time(const PtpHostState& state, double max_offset_ns);

// One line for logs and events: "SLAVE of 860239.fffe.868401, offset -58 ns, path delay 2368 ns".
std::string describe(const PtpHostState& state);

// Reads the state from ptp4l's socket `ptp4l_socket` (ptp4l's `uds_address`, /var/run/ptp4l by
// default) by running `pmc -u -b 0 -s SOCKET GET ...`, at most `time_limit`.
class PmcClient {
 public:
  explicit PmcClient(std::filesystem::path ptp4l_socket,
                     std::chrono::milliseconds time_limit = std::chrono::milliseconds(1000));
  Result<PtpHostState> query() const;
  const std::filesystem::path& socket() const { return socket_; }

 private:
  std::filesystem::path socket_;
  std::chrono::milliseconds time_limit_;
};

}  // namespace pvcap::sync
