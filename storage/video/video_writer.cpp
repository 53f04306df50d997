#include "storage/video/video_writer.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/error.h>
#include <libavutil/opt.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include <optional>
#include <vector>

#include <fmt/format.h>
#include "core/durable_folder.h"
#include "storage/video/av_handles.h"
#include "storage/video/av_log.h"
#include "storage/video/bayer_planes.h"

namespace pvcap {

namespace {
constexpr AVRational kMicros{1, 1'000'000};
}  // namespace

struct VideoWriter::Impl {  // members are freed in reverse: the scaler first, the container last
  av::OutputFormat fmt;
  struct Coder {  // one stream: the whole picture, or one tile of a raw video's
    av::CodecContext enc;
    AVStream* stream = nullptr;  // owned by fmt
    av::Frame frame;
  };
  std::vector<Coder> coders;
  av::Packet packet;
  av::Scaler sws;
  cv::Mat ycbcr;   // yuv444p: the converted image before it is split into the frame's planes
  cv::Mat planes;  // a tiled raw video: the whole mosaic's planes, before they are cut into tiles
  bool header_written = false;
  bool matroska = true;
  bool wrote = false;  // a packet since the last cluster ended
  Status open_coder(const VideoSettings& s, const AVCodec* codec, AVPixelFormat pix, cv::Size picture,
                    const TileGrid& grid, int t, const std::string& where);
};

// The encoder and stream of tile `t` (or of the whole picture).
Status VideoWriter::Impl::open_coder(const VideoSettings& s, const AVCodec* codec, AVPixelFormat pix, cv::Size picture,
                                     const TileGrid& grid, int t, const std::string& where) {
  Coder& c = coders[std::size_t(t)];
  const std::string codec_name = s.stored_codec();
  c.enc.ptr = avcodec_alloc_context3(codec);
  AVCodecContext* enc = c.enc.ptr;
  enc->width = picture.width;
  enc->height = picture.height;
  enc->pix_fmt = pix;
  enc->time_base = kMicros;
  enc->framerate = av_d2q(s.nominal_fps > 0 ? s.nominal_fps : 30, 1000);
  enc->gop_size = std::max(1, s.gop_frames);
  enc->keyint_min = 1;
  enc->max_b_frames = 0;
  // A tile is small; and a frame's tiles must leave their encoders together (no frame threads' delay).
  enc->thread_count = grid.tiled() ? 1 : s.threads;
  if (fmt.ptr->oformat->flags & AVFMT_GLOBALHEADER) enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  if (!s.residual_counts.empty() && codec_name == "ffvhuff") {
    // HuffYUV's second pass reads four tables of counts (the grey picture uses the first).
    std::string stats;
    for (int table = 0; table < 4; ++table) {
      for (std::size_t v = 0; v < 256; ++v)
        stats += std::to_string(table == 0 && v < s.residual_counts.size() ? s.residual_counts[v] : 0) + ' ';
      stats += '\n';
    }
    enc->flags |= AV_CODEC_FLAG_PASS2;
    enc->stats_in = av_strdup(stats.c_str());  // freed with the context
  }
  AVDictionary* opts = nullptr;
  if (codec_name == "libx264") {
    av_dict_set(&opts, "preset", s.preset.c_str(), 0);
    if (s.raw())
      av_dict_set(&opts, "qp", "0", 0);  // lossless
    else
      av_dict_set(&opts, "crf", std::to_string(s.crf).c_str(), 0);
    // Tiles: no look-ahead, so each frame's tiles leave their encoders with it, and a decoder hands
    // each out at once (storage/video/video_reader.cpp reads a frame's tiles together); no key frame
    // of a tile's own choosing (scenecut), so every tile's key frames are the same frames and a seek
    // to one is a seek to all. A tile is small enough for one slice. In-band SPS/PPS on every key
    // frame: any GOP decodes on its own.
    if (grid.tiled()) av_dict_set(&opts, "tune", "zerolatency", 0);
    av_dict_set(&opts, "x264-params",
                grid.tiled() ? "repeat-headers=1:bframes=0:scenecut=0" : "repeat-headers=1:bframes=0:slices=4", 0);
  } else if (codec_name == "magicyuv") {
    av_dict_set(&opts, "pred", "median", 0);  // the fastest of its predictors here, as small as left
  } else if (codec_name == "ffv1") {
    av_dict_set(&opts, "level", "3", 0);
    av_dict_set(&opts, "slicecrc", "1", 0);
  }
  if (s.raw() && !s.raw_codec_options.empty() &&
      av_dict_parse_string(&opts, s.raw_codec_options.c_str(), "=", ":", 0) < 0) {
    av_dict_free(&opts);
    return Error{fmt::format("{}: '{}' is not a list of codec options (key=value:key=value)", where,
                             s.raw_codec_options)};
  }
  int rc = 0;
  {
    // HuffYUV with adaptive tables says at every open that it encodes on one thread (as asked):
    // not news for the operator's console; a failure is returned below, named.
    std::optional<FfmpegLogQuiet> quiet;
    if (!s.raw_codec_options.empty()) quiet.emplace();
    rc = avcodec_open2(enc, codec, &opts);
  }
  const bool unused = !s.raw_codec_options.empty() && av_dict_count(opts) > 0;
  av_dict_free(&opts);
  if (rc >= 0 && unused)
    return Error{fmt::format("{}: {} does not take every option of '{}'", where, codec_name, s.raw_codec_options)};
  if (rc < 0)
    return Error{fmt::format("{}: cannot open encoder {} for {}x{} {}: {}", where, codec_name, picture.width,
                             picture.height, s.stored_pixel_format(), av::error(rc))};
  c.stream = avformat_new_stream(fmt.ptr, nullptr);
  if (s.raw()) {
    // The file says what it holds, so a raw video is readable without the index.
    av_dict_set(&c.stream->metadata, "PVCAP_LAYOUT", s.layout.c_str(), 0);
    av_dict_set(&c.stream->metadata, "PVCAP_BAYER_FORMAT", s.bayer_format.c_str(), 0);
    av_dict_set(&c.stream->metadata, "PVCAP_BIT_DEPTH", std::to_string(s.bit_depth).c_str(), 0);
    av_dict_set(&c.stream->metadata, "PVCAP_SIZE", fmt::format("{}x{}", s.width, s.height).c_str(), 0);
    if (grid.tiled()) {
      av_dict_set(&c.stream->metadata, "PVCAP_TILES", grid.tag().c_str(), 0);
      av_dict_set(&c.stream->metadata, "PVCAP_TILE", std::to_string(t).c_str(), 0);
    }
  }
  c.stream->time_base = {1, 1000};
  avcodec_parameters_from_context(c.stream->codecpar, enc);
  return {};
}

Result<std::unique_ptr<VideoWriter>> VideoWriter::open(const std::filesystem::path& path, const VideoSettings& s) {
  route_ffmpeg_log();
  std::unique_ptr<VideoWriter> w(new VideoWriter());
  w->path_ = path;
  w->impl_ = std::make_unique<Impl>();
  Impl& im = *w->impl_;
  const std::string where = path.string();

  const std::string codec_name = s.stored_codec();
  const AVCodec* codec = avcodec_find_encoder_by_name(codec_name.c_str());
  if (!codec)
    return Error{fmt::format("{}: FFmpeg has no encoder '{}' ({})", where, codec_name,
                             s.raw() ? "store.raw_codec" : "store.video_codec")};
  const AVPixelFormat pix = av_get_pix_fmt(s.stored_pixel_format().c_str());
  if (pix == AV_PIX_FMT_NONE)
    return Error{fmt::format("{}: unknown pixel format '{}' (store.video_pixel_format)", where, s.pixel_format)};
  if (s.raw() && s.bit_depth > 8 && (codec_name == "libx264" || codec_name == "magicyuv"))
    return Error{fmt::format("{}: {} keeps {}; a {}-bit {} mosaic needs store.raw_codec ffvhuff or ffv1", where,
                             codec_name, codec_name == "libx264" ? "at most 10 bits" : "8-bit grey only", s.bit_depth,
                             s.bayer_format)};
  if (s.raw() && (s.bit_depth < 8 || s.bit_depth > 16))
    return Error{fmt::format("{}: a raw video of {} bits per sample is not possible", where, s.bit_depth)};
  if (s.raw()) {
    auto order = pvcap::plane_order(s.layout, s.bayer_format);
    if (!order) return Error{fmt::format("{}: {}", where, order.error().message)};
    w->order_ = order.value();
  }
  if (s.raw() && (s.width % 2 != 0 || s.height % 2 != 0))
    return Error{
        fmt::format("{}: a {} mosaic of {}x{} has no whole 2x2 cells; raw video needs an even width and "
                    "height (or store.video_mode: color)",
                    where, s.bayer_format, s.width, s.height)};
  // In raw mode the codec sees the four planes stacked: half the width, twice the height.
  const cv::Size coded = s.raw() ? bayer_planes_size({s.width, s.height}) : cv::Size(s.width, s.height);
  im.matroska = s.container == "matroska";
  int rc = avformat_alloc_output_context2(&im.fmt.ptr, nullptr, s.container.c_str(), path.c_str());
  if (rc < 0) return Error{fmt::format("{}: cannot create a {} file: {}", where, s.container, av::error(rc))};
  w->grid_ = s.raw() ? pvcap::tile_grid({s.width, s.height}, s.tile_cols, s.tile_rows) : TileGrid{1, 1, {s.width, s.height}};
  const cv::Size picture = w->grid_.tiled() ? bayer_planes_size(w->grid_.tile_size()) : coded;
  im.coders.resize(std::size_t(w->grid_.count()));
  for (int t = 0; t < w->grid_.count(); ++t)
    if (Status st = im.open_coder(s, codec, pix, picture, w->grid_, t, where); !st.ok()) return st.error();
  rc = avio_open(&im.fmt.ptr->pb, path.c_str(), AVIO_FLAG_WRITE);
  if (rc < 0) return Error{fmt::format("{}: cannot create the video file: {}", where, av::error(rc))};
  AVDictionary* mux = nullptr;
  // Every frame ends its cluster (encode()); the limit is a second guard.
  if (s.container == "matroska") av_dict_set(&mux, "cluster_time_limit", "200", 0);
  im.fmt.ptr->flags |= AVFMT_FLAG_FLUSH_PACKETS;
  rc = avformat_write_header(im.fmt.ptr, &mux);
  av_dict_free(&mux);
  if (rc < 0) return Error{fmt::format("{}: cannot write the video header: {}", where, av::error(rc))};
  im.header_written = true;
  for (Impl::Coder& c : im.coders) {
    c.frame.ptr = av_frame_alloc();
    c.frame.ptr->format = pix;
    c.frame.ptr->width = picture.width;
    c.frame.ptr->height = picture.height;
    if ((rc = av_frame_get_buffer(c.frame.ptr, 0)) < 0) return Error{fmt::format("{}: {}", where, av::error(rc))};
  }
  im.packet.ptr = av_packet_alloc();
  w->raw_ = s.raw();
  w->input_type_ = !s.raw() ? CV_8UC3 : s.bit_depth > 8 ? CV_16UC1 : CV_8UC1;
  w->width_ = s.width;
  w->height_ = s.height;
  if (s.raw()) return w;
  im.sws.ptr =
      sws_getContext(s.width, s.height, AV_PIX_FMT_BGR24, s.width, s.height, pix, SWS_AREA, nullptr, nullptr, nullptr);
  if (!im.sws.ptr) return Error{fmt::format("{}: no conversion from BGR to {}", where, s.pixel_format)};
  return w;
}

VideoWriter::~VideoWriter() { (void)close(); }

Status VideoWriter::encode(std::size_t tile, bool flush) {
  Impl& im = *impl_;
  Impl::Coder& c = im.coders[tile];
  int rc = avcodec_send_frame(c.enc.ptr, flush ? nullptr : c.frame.ptr);
  if (rc < 0 && rc != AVERROR_EOF) return Error{fmt::format("{}: encoder: {}", path_.string(), av::error(rc))};
  while ((rc = avcodec_receive_packet(c.enc.ptr, im.packet.ptr)) >= 0) {
    // MP4 plays a frame for its duration and drops a last frame without one: give each the nominal
    // frame time (Matroska files, the store's, need none: each frame's timestamp is what counts).
    if (im.packet.ptr->duration == 0 && !im.matroska)
      im.packet.ptr->duration = av_rescale_q(1, av_inv_q(c.enc.ptr->framerate), c.enc.ptr->time_base);
    av_packet_rescale_ts(im.packet.ptr, c.enc.ptr->time_base, c.stream->time_base);
    im.packet.ptr->stream_index = c.stream->index;
    // Tiles go straight to the muxer, in the order written (each frame's tiles one after another):
    // its interleaving would hold a frame's tiles back until the next frame's came.
    rc = im.coders.size() > 1 ? av_write_frame(im.fmt.ptr, im.packet.ptr)
                              : av_interleaved_write_frame(im.fmt.ptr, im.packet.ptr);
    av_packet_unref(im.packet.ptr);
    if (rc < 0) return Error{fmt::format("{}: cannot write video: {}", path_.string(), av::error(rc))};
    im.wrote = true;
  }
  if (rc != AVERROR(EAGAIN) && rc != AVERROR_EOF)
    return Error{fmt::format("{}: encoder: {}", path_.string(), av::error(rc))};
  return {};
}

Status VideoWriter::end_cluster() {
  // The muxer holds a Matroska cluster until the next one begins: an encoder then held up (a busy
  // disk, a stalled thread) would keep its last frame out of the file, and a power cut would take
  // a frame seconds old. Ending the cluster now hands the frame to the kernel, whose data the next
  // sync round makes durable (docs/store.md).
  if (!impl_->matroska || !impl_->wrote) return {};
  impl_->wrote = false;
  const int rc = av_write_frame(impl_->fmt.ptr, nullptr);
  if (rc < 0) return Error{fmt::format("{}: cannot write video: {}", path_.string(), av::error(rc))};
  return {};
}

Result<std::int64_t> VideoWriter::write(const cv::Mat& bgr, std::int64_t pts_us) {
  Impl& im = *impl_;
  if (closed_) return Error{fmt::format("{}: write after close", path_.string())};
  if (bgr.type() != input_type_ || bgr.cols != width_ || bgr.rows != height_)
    return Error{fmt::format("{}: frame is {}x{} of type {}, the video takes {}x{} {}", path_.string(), bgr.cols,
                             bgr.rows, cv::typeToString(bgr.type()), width_, height_,
                             !raw_                     ? "BGR images (CV_8UC3)"
                             : input_type_ == CV_16UC1 ? "16-bit mosaics (CV_16UC1)"
                                                       : "mosaics (CV_8UC1)")};
  // The container keeps milliseconds: round to them here (so the stored timestamp is exactly
  // last_pts_ms()), and keep them strictly increasing (frames that arrived in a burst).
  std::int64_t pts_ms = (pts_us + (pts_us >= 0 ? 500 : -500)) / 1000;
  if (frames_ > 0 && pts_ms <= last_pts_ms_) pts_ms = last_pts_ms_ + 1;
  last_pts_ms_ = pts_ms;
  pts_us = pts_ms * 1000;
  for (Impl::Coder& c : im.coders) {
    const int rc = av_frame_make_writable(c.frame.ptr);
    if (rc < 0) return Error{fmt::format("{}: {}", path_.string(), av::error(rc))};
    c.frame.ptr->pts = pts_us;
  }
  AVFrame* frame = im.coders[0].frame.ptr;
  const auto frame_picture = [this](AVFrame* f) {
    return cv::Mat(f->height, f->width, input_type_, f->data[0], std::size_t(f->linesize[0]));
  };
  const std::uint8_t* src[1] = {bgr.data};
  const int src_stride[1] = {int(bgr.step[0])};
  if (raw_ && grid_.tiled()) {
    pack_bayer_planes(bgr, im.planes, order_);
    for (int t = 0; t < grid_.count(); ++t) {
      cv::Mat tile = frame_picture(im.coders[std::size_t(t)].frame.ptr);
      copy_tile_from_planes(im.planes, grid_, t, tile);
    }
  } else if (raw_) {
    cv::Mat planes = frame_picture(frame);
    pack_bayer_planes(bgr, planes, order_);
  } else if (im.coders[0].enc.ptr->pix_fmt == AV_PIX_FMT_YUV444P) {
    // The default format, converted here rather than by swscale (3x faster for this pair): BT.601
    // limited range, the coefficients swscale uses, straight into the frame's three planes.
    static const cv::Matx34f kBgrToYCbCr(25.064f / 256, 129.057f / 256, 65.738f / 256, 16.f,     //
                                         112.439f / 256, -74.494f / 256, -37.945f / 256, 128.f,  //
                                         -18.285f / 256, -94.154f / 256, 112.439f / 256, 128.f);
    cv::transform(bgr, im.ycbcr, kBgrToYCbCr);
    std::vector<cv::Mat> planes;
    for (int p = 0; p < 3; ++p)
      planes.emplace_back(bgr.rows, bgr.cols, CV_8UC1, frame->data[p], std::size_t(frame->linesize[p]));
    cv::split(im.ycbcr, planes);
  } else {
    sws_scale(im.sws.ptr, src, src_stride, 0, bgr.rows, frame->data, frame->linesize);
  }
  for (std::size_t t = 0; t < im.coders.size(); ++t)
    if (Status s = encode(t, false); !s.ok()) return s.error();
  if (Status s = end_cluster(); !s.ok()) return s.error();
  return frames_++;
}

cv::Mat VideoWriter::stored_planes() const {
  if (!raw_ || frames_ == 0 || !impl_) return {};
  if (grid_.tiled()) return impl_->planes;
  const AVFrame* f = impl_->coders[0].frame.ptr;
  return cv::Mat(f->height, f->width, input_type_, f->data[0], std::size_t(f->linesize[0]));
}

// The frames tile encoders still hold (an encoder that looks ahead), a frame's tiles together: one
// packet from each encoder in turn, so the file keeps each frame's tiles one after another.
Status VideoWriter::flush_tiles() {
  Impl& im = *impl_;
  for (Impl::Coder& c : im.coders) avcodec_send_frame(c.enc.ptr, nullptr);
  for (bool more = true; more;) {
    more = false;
    for (Impl::Coder& c : im.coders) {
      int rc = avcodec_receive_packet(c.enc.ptr, im.packet.ptr);
      if (rc == AVERROR_EOF || rc == AVERROR(EAGAIN)) continue;
      if (rc < 0) return Error{fmt::format("{}: encoder: {}", path_.string(), av::error(rc))};
      av_packet_rescale_ts(im.packet.ptr, c.enc.ptr->time_base, c.stream->time_base);
      im.packet.ptr->stream_index = c.stream->index;
      rc = av_write_frame(im.fmt.ptr, im.packet.ptr);
      av_packet_unref(im.packet.ptr);
      if (rc < 0) return Error{fmt::format("{}: cannot write video: {}", path_.string(), av::error(rc))};
      more = true;
    }
  }
  return {};
}

Status VideoWriter::close() {
  if (closed_ || !impl_ || !impl_->header_written) return {};
  closed_ = true;
  Status s = impl_->coders.size() > 1 ? flush_tiles() : encode(0, true);
  const int rc = av_write_trailer(impl_->fmt.ptr);
  if (s.ok() && rc < 0) s = Error{fmt::format("{}: cannot finish the video: {}", path_.string(), av::error(rc))};
  avio_closep(&impl_->fmt.ptr->pb);
  // A finished file is final on disk before its index row says "closed" (recover leaves closed
  // files alone): its trailer rewrote the header, which the last periodic fsync did not see.
  if (s.ok()) s = sync_to_disk(path_);
  return s;
}

}  // namespace pvcap
