#pragma once
// What the session's pages show, as the JSON the pages and the tests read (GET /state, and each
// server-sent event): the recording's status, the protocol runner's view when one runs, the latest
// pressure, which pages are open. Pure: built from snapshots, so it is tested without a server.
#include <optional>

#include <nlohmann/json.hpp>

#include "protocol/runner.h"
#include "session/recording_status.h"

namespace pvcap::console {

inline constexpr double kLiveWindowMs = 250;  // the recording indicator's window

struct PageCounts {
  int participant = 0, operator_pages = 0;
};

nlohmann::json status_model(const session::RecordingStatus& status, std::size_t cameras,
                            const std::optional<session::PressureSnapshot>& pressure, PageCounts pages,
                            const protocol::RunnerView* runner);

}  // namespace pvcap::console
