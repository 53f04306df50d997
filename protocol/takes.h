#pragma once
// The takes of a recorded session, rebuilt from its protocol events: every take
// with its action, hand, force level, status (done, superseded, skipped, bad,
// interrupted), times on the session clock, sample range, and what the pressure
// amounted to while it recorded. Follows a resumed session back through the
// folders it continues.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/result.h"

namespace pvcap::protocol {

struct TakeRow {
  std::string session;  // the folder it was recorded in
  int step = 0;
  std::string sequence, action, hand, force, status;
  int repetitions = 0;
  std::optional<std::int64_t> start_ns, end_ns;         // session clock; none for a take skipped at its prompt
  std::int64_t session_start_ns = 0;                    // its folder's start, for times in seconds from it
  std::optional<std::size_t> first_sample, end_sample;  // [first, end) in its session's samples
  double mean_newtons = 0, peak_newtons = 0, mean_contact_mm2 = 0, peak_contact_mm2 = 0;
  std::size_t pressure_frames = 0;
  std::optional<bool> check_ok;
  std::vector<std::string> check_problems;  // what the take check found, as the operator was told
  // The lighting commanded for the take and what its images showed (docs/lighting.md); empty on a rig
  // without lights. `lights_disagreeing`: the letters of the lights whose state the images contradict.
  std::string lighting_commanded, lighting_seen;
  std::string lights_disagreeing;
};

struct SessionTakes {
  std::vector<std::string> folders;  // oldest first (a resumed session's earlier folders first)
  nlohmann::json protocol_start;     // the latest folder's protocol_start detail (protocol, hand order...)
  std::vector<TakeRow> takes;
  int plan_steps = 0;
};

Result<SessionTakes> read_takes(const std::filesystem::path& session_dir);

// The first step of the plan without a done (or bad) take: where a resumed session begins.
int first_incomplete_step(const SessionTakes& t);

// The table printed by `pvcap takes`, and the per-force summary (the paper's High/Low/No contact means).
std::string format_takes(const SessionTakes& t);
nlohmann::json takes_json(const SessionTakes& t);

}  // namespace pvcap::protocol
