#pragma once
// The host's PTP time over a session (rig file `ptp:`; docs/multihost.md), from the events the
// recording stored each second (session/ptp_host_watch.h): how many readings, how far from its
// master the host was at worst, which grandmaster it followed, and each stretch out of time.
#include <cstdint>
#include <map>
#include <string>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "storage/index/records.h"

namespace pvcap::report {

// The host's: {"readings": n, "in_time": n, "seconds_out_of_time": n, "worst_offset_ns": x, "grandmasters": [...],
//  "port_states": [...], "out_of_time": [{"from_s", "to_s", "seconds", "why"}]}; nullopt for a
// session recorded without `ptp:` (no such events).
// With cameras on PTP (events ptp_camera_state / ptp_camera_out_of_lock, named by `camera_names`),
// "cameras": [{"name", "readings", "locked", "seconds_out_of_lock", "worst_offset_ns", "out_of_lock": [...]}].
std::optional<nlohmann::json> ptp_time_section(const std::vector<EventRecord>& events, std::int64_t start_ns,
                                               const std::map<std::int64_t, std::string>& camera_names = {});

// Event kinds a report lists in its section rather than among the events: one a second.
inline bool is_ptp_reading(const EventRecord& e) { return e.kind == "ptp_host_state" || e.kind == "ptp_camera_state"; }

}  // namespace pvcap::report
