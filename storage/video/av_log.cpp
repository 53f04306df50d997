#include "storage/video/av_log.h"

extern "C" {
#include <libavutil/log.h>
}

#include <cstdarg>
#include <mutex>
#include <string>

#include <spdlog/spdlog.h>

namespace pvcap {

namespace {
thread_local int quiet_depth = 0;
}

void route_ffmpeg_log() {
  static std::once_flag once;
  std::call_once(once, [] {
    av_log_set_callback([](void* avcl, int level, const char* fmt, va_list args) {
      if (level > AV_LOG_VERBOSE) return;
      char line[1024];
      int print_prefix = 1;
      av_log_format_line2(avcl, level, fmt, args, line, sizeof line, &print_prefix);
      std::string text(line);
      while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
      if (text.empty()) return;
      if (quiet_depth > 0 || level > AV_LOG_WARNING)
        spdlog::debug("ffmpeg: {}", text);
      else if (level <= AV_LOG_ERROR)
        spdlog::error("ffmpeg: {}", text);
      else
        spdlog::warn("ffmpeg: {}", text);
    });
  });
}

FfmpegLogQuiet::FfmpegLogQuiet() { ++quiet_depth; }
FfmpegLogQuiet::~FfmpegLogQuiet() { --quiet_depth; }

}  // namespace pvcap
