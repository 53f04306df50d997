#pragma once
// Rendered scenes kept on disk between runs of the simulator. Rendering one camera's 1080p scene (a
// ray per pixel, the pad's texture, the fixed noise) costs 0.3-0.4 s of a core, and a simulated rig
// renders all of its cameras each time it starts: about 1.4 s before a session's first frame, on
// every one of the test suite's many sessions. The render is deterministic, so the same inputs give
// the same bytes: a scene is stored under a key that names every input and the executable that
// rendered it (its size, time and inode: a rebuilt pvcap renders afresh, so a change to the
// renderer can never meet an old picture). Checked on reading (its key in full, its size, a CRC);
// anything else is rendered again. A cache only: any failure to read or write it costs the render.
//
// Where: $PVCAP_SIM_CACHE (empty or "off": no cache), else $XDG_CACHE_HOME/pvcap/sim-scenes, else
// ~/.cache/pvcap/sim-scenes. At most kSceneCacheBytes of scenes (~120 of 1080p Bayer), the least
// recently used removed first. A rebuilt pvcap's scenes are new files, so a developer's cache fills
// with old builds' scenes until they are evicted (the test suite uses 21 different scenes).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace pvcap::sim {

inline constexpr std::uintmax_t kSceneCacheBytes = 256ull << 20;

// The cache folder as configured, or nothing when caching is off or no folder can be named.
std::optional<std::filesystem::path> scene_cache_dir();

// The picture stored under `key` in `dir`, or `render()`'s (then stored, best effort). `key`
// names the inputs; the executable's identity is added here.
// `budget`: the bytes of scenes the folder keeps.
cv::Mat cached_scene(const std::optional<std::filesystem::path>& dir, const std::string& key,
                     const std::function<cv::Mat()>& render, std::uintmax_t budget = kSceneCacheBytes);

}  // namespace pvcap::sim
