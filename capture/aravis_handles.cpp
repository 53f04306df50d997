#include "capture/aravis_handles.h"

#include <pthread.h>

#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <utility>

#include <spdlog/spdlog.h>

namespace pvcap::arv {

namespace {

// Never destroyed: its thread may still be waiting on a lost camera when the process exits.
class BackgroundReleases {
 public:
  static BackgroundReleases& get() {
    static auto* releases = new BackgroundReleases;
    return *releases;
  }
  void add(std::function<void()> release) {
    {
      std::lock_guard lock(mu_);
      pending_.push_back(std::move(release));
    }
    cv_.notify_one();
  }

 private:
  BackgroundReleases() {
    std::thread([this] {
      pthread_setname_np(pthread_self(), "arv-release");
      for (;;) {
        std::function<void()> release;
        {
          std::unique_lock lock(mu_);
          cv_.wait(lock, [&] { return !pending_.empty(); });
          release = std::move(pending_.front());
          pending_.pop_front();
        }
        release();
      }
    }).detach();
  }
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> pending_;
};

}  // namespace

void release_in_background(std::function<void()> release) { BackgroundReleases::get().add(std::move(release)); }

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
