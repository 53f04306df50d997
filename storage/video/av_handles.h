#pragma once
// The libav* edge: RAII owners of FFmpeg's objects (each freed the one right way, in one place) and
// its error text, shared by the video writer, the reader and the repair. The raw pointer stays
// public: these are thin handles for the few files that talk to libav*, nothing more.
#include <string>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libswscale/swscale.h>
}

namespace pvcap::av {

template <typename T, void (*Free)(T*&)>
struct Handle {
  T* ptr = nullptr;
  Handle() = default;
  explicit Handle(T* p) : ptr(p) {}
  ~Handle() { Free(ptr); }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : ptr(o.ptr) { o.ptr = nullptr; }  // kept in vectors (one encoder per tile)
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      Free(ptr);
      ptr = o.ptr;
      o.ptr = nullptr;
    }
    return *this;
  }
  T* operator->() const { return ptr; }
  explicit operator bool() const { return ptr != nullptr; }
};

namespace detail {
inline void close_input(AVFormatContext*& c) { avformat_close_input(&c); }
inline void free_output(AVFormatContext*& c) {
  if (!c) return;
  if (c->pb && !(c->oformat->flags & AVFMT_NOFILE)) avio_closep(&c->pb);
  avformat_free_context(c);
  c = nullptr;
}
inline void free_codec(AVCodecContext*& c) { avcodec_free_context(&c); }
inline void free_frame(AVFrame*& f) { av_frame_free(&f); }
inline void free_packet(AVPacket*& p) { av_packet_free(&p); }
inline void free_scaler(SwsContext*& s) {
  sws_freeContext(s);
  s = nullptr;
}
}  // namespace detail

using InputFormat = Handle<AVFormatContext, detail::close_input>;   // avformat_open_input
using OutputFormat = Handle<AVFormatContext, detail::free_output>;  // avformat_alloc_output_context2
using CodecContext = Handle<AVCodecContext, detail::free_codec>;
using Frame = Handle<AVFrame, detail::free_frame>;
using Packet = Handle<AVPacket, detail::free_packet>;
using Scaler = Handle<SwsContext, detail::free_scaler>;

// FFmpeg's text for an error code.
inline std::string error(int rc) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(rc, buf, sizeof buf);
  return buf;
}

}  // namespace pvcap::av
