#pragma once
// What SessionWriter holds per camera, shared by its two files: session_writer.cpp (the store's
// life: create, start, the free-space and sync threads, close) and session_writer_encode.cpp (each
// camera's encoder thread).
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "storage/video/view_video_writer.h"
#include "storage/writer/frame_spill.h"
#include "storage/writer/session_writer.h"

namespace pvcap {

struct SessionWriter::Camera {
  std::int64_t device_id = 0;
  std::string name;
  VideoSettings settings;
  // The open segment (encoder thread only, after start()).
  std::unique_ptr<VideoWriter> video;
  std::int64_t video_file_id = 0;
  int segment = -1;
  std::int64_t segment_start_us = 0;
  std::vector<std::int64_t> failed_files;  // segments a write failed in: reconciled at close
  // The open segment's view video (storage/video/view_video.h), when store.view_videos.
  std::unique_ptr<ViewVideoWriter> view;
  std::unique_ptr<FrameSpillQueue> queue;  // made at add_camera, when the session folder exists
  std::thread thread;
  std::atomic<std::uint64_t> in_video{0}, encoder_drops{0}, segments{0};
  std::atomic<bool> failed{false};
};

}  // namespace pvcap
