#pragma once
// FFmpeg's own log, routed into pvcap's (spdlog) instead of raw lines on the operator's console.

namespace pvcap {

// Installs the routing (once per process; later calls do nothing).
void route_ffmpeg_log();

// While one is alive on a thread, FFmpeg's messages from that thread go to the debug log only. For
// readers: they report every failure themselves, naming the file, and a store cut by a crash is
// expected to end early ("File ended prematurely" is not news to whoever runs `pvcap recover`).
class FfmpegLogQuiet {
 public:
  FfmpegLogQuiet();
  ~FfmpegLogQuiet();
  FfmpegLogQuiet(const FfmpegLogQuiet&) = delete;
  FfmpegLogQuiet& operator=(const FfmpegLogQuiet&) = delete;
};

}  // namespace pvcap
