#pragma once
// The report's sections on what the session asked of the participant: the protocol's takes (with
// the lighting commanded and seen for each), and the lights' check and switches (docs/report.md,
// docs/lighting.md).
#include <cstdint>
#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>

#include "storage/index/session_reader.h"

namespace pvcap::report {

// The takes of the session's protocol (and the folders it continues); a note when none was run.
// Throws UserError when a read fails on the disk.
nlohmann::json protocol_section(const std::filesystem::path& dir, std::int64_t start_ns);
// The light check and every switch as the images confirmed it; nullopt for a session that switched
// no lights.
std::optional<nlohmann::json> lighting_section(SessionReader& r, std::int64_t start_ns);

}  // namespace pvcap::report
