#include "capture/aravis_handles.h"

#include <mutex>

#include <spdlog/spdlog.h>

namespace pvcap::arv {

void route_glib_logs_to_spdlog() {
  static std::once_flag once;
  std::call_once(once, [] {
    g_log_set_handler(
        "Aravis", GLogLevelFlags(G_LOG_LEVEL_MASK | G_LOG_FLAG_FATAL | G_LOG_FLAG_RECURSION),
        [](const gchar*, GLogLevelFlags level, const gchar* message, gpointer) {
          if (level & (G_LOG_LEVEL_ERROR | G_LOG_LEVEL_CRITICAL))
            spdlog::error("aravis: {}", message);
          else if (level & G_LOG_LEVEL_WARNING)
            spdlog::warn("aravis: {}", message);
          else
            spdlog::debug("aravis: {}", message);
        },
        nullptr);
  });
}

}  // namespace pvcap::arv
