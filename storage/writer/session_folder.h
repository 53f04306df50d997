#pragma once
// A new session folder, made whole or not at all: its index (schema and session row) is written in
// a hidden `.starting-<name>-<pid>` folder, which is renamed into place (never over an existing
// session), and the sessions folder's entry is synced. A start killed in between leaves a hidden
// folder that no reader takes for a session, never a session folder with an empty index
// (StoreCrash.KillNineAtEveryPhase...: "not a pvcap session index").
#include <cstdint>
#include <filesystem>
#include <string>

#include "core/result.h"
#include "core/rig_config.h"

namespace pvcap {

// `rig.name` made safe for a file name: letters, digits, '-' and '_' kept, anything else '-'.
std::string safe_file_name(std::string name);

// The folder `<root>/<UTC start>_<rig name>[-N]` with its index, owned by `rig.store.group` when
// one is named (setgid, so what is made in it is the group's). Leftovers of starts killed earlier
// in `root` are tidied first.
Result<std::filesystem::path> make_session_folder(const std::filesystem::path& root, const RigConfig& rig,
                                                  std::int64_t started_wall_ns, std::int64_t started_host_ns);

}  // namespace pvcap
