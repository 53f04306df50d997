#pragma once
// The GObject/GError edge of Aravis, wrapped so the rest of pvcap never calls
// g_object_unref or g_error_free by hand.
#include <functional>
#include <memory>
#include <string>

#include <arv.h>

namespace pvcap::arv {

struct GObjectUnref {
  void operator()(void* p) const {
    if (p) g_object_unref(p);
  }
};
template <typename T>
using GPtr = std::unique_ptr<T, GObjectUnref>;

// Collects a GError from an Aravis call; `take()` returns its message and frees it.
class GErrorSlot {
 public:
  GErrorSlot() = default;
  GErrorSlot(const GErrorSlot&) = delete;
  GErrorSlot& operator=(const GErrorSlot&) = delete;
  ~GErrorSlot() { g_clear_error(&error_); }
  GError** out() {
    g_clear_error(&error_);
    return &error_;
  }
  explicit operator bool() const { return error_ != nullptr; }
  std::string message() const { return error_ ? error_->message : ""; }

 private:
  GError* error_ = nullptr;
};

// Runs `release` on a thread of its own, after the releases handed over before it. Finalizing the
// stream of a camera that no longer answers waits on GVCP's timeouts (Aravis 0.8.26 writes the
// stream channel register, then the device joins its heartbeat's read and leaves control: 5 tries of
// 500 ms each, 10 s measured here), and no capture, encoding or stopping thread may wait for that. A
// release still waiting when the process exits is abandoned: the camera is gone, nothing is left to
// tell it.
void release_in_background(std::function<void()> release);

// Aravis reports through GLib's log; route it into spdlog once per process.
void route_glib_logs_to_spdlog();

}  // namespace pvcap::arv
