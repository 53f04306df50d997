#include "storage/video/video_reader.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/imgutils.h>
#include <libswscale/swscale.h>
}

#include <cstdlib>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "core/frame_pool.h"
#include "storage/video/av_handles.h"
#include "storage/video/av_log.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/frame_checksum.h"

namespace pvcap {

struct VideoReader::Impl {  // members are freed in reverse: the scaler first, the container last
  av::InputFormat fmt;
  av::CodecContext dec;
  av::Frame frame;
  av::Packet packet;
  av::Scaler sws;
  cv::Mat ycbcr;        // yuv444p: the frame's planes merged, before conversion
  cv::Mat mosaic;       // raw videos: the frame's mosaic, before demosaicing
  cv::Mat bgr16;        // raw videos of more than 8 bits: demosaiced, before the 8-bit colour image
  FramePool images{4};  // the BGR images handed out: reused once the caller has dropped them
  int stream = -1;
  bool draining = false;
  bool intra_only = false;  // every frame decodes alone (HuffYUV, MagicYUV; not FFV1): reads skip, not decode
};

Result<std::unique_ptr<VideoReader>> VideoReader::open(const std::filesystem::path& path, const Options& options) {
  route_ffmpeg_log();
  const FfmpegLogQuiet quiet;
  std::unique_ptr<VideoReader> r(new VideoReader());
  r->path_ = path;
  r->impl_ = std::make_unique<Impl>();
  Impl& im = *r->impl_;
  if (const int rc = avformat_open_input(&im.fmt.ptr, path.c_str(), nullptr, nullptr); rc < 0) {
    // The disk failing the header's read is not a damaged file: said as such (and never skipped).
    if (rc == AVERROR(EIO)) return Error{fmt::format("{}: cannot be read: {}", path.string(), av::error(rc)), true};
    return Error{fmt::format("{}: not a readable video file", path.string())};
  }
  // Matroska's header names the codec, the size and the parameter sets: probing (decoding the first
  // frames to learn what the header already says) would cost every first access a GOP. Only a file
  // whose header leaves the picture size open is probed.
  const auto header_complete = [&] {
    for (unsigned i = 0; i < im.fmt.ptr->nb_streams; ++i) {
      const AVCodecParameters* p = im.fmt.ptr->streams[i]->codecpar;
      if (p->codec_type == AVMEDIA_TYPE_VIDEO && p->width > 0 && p->height > 0) return true;
    }
    return false;
  };
  if (!header_complete() && avformat_find_stream_info(im.fmt.ptr, nullptr) < 0)
    return Error{fmt::format("{}: no stream information", path.string())};
  const AVCodec* codec = nullptr;
  im.stream = av_find_best_stream(im.fmt.ptr, AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  if (im.stream < 0 || !codec) return Error{fmt::format("{}: no decodable video stream", path.string())};
  // A raw video names its layout in its tags (storage/video/video_writer.cpp).
  const AVDictionary* tags = im.fmt.ptr->streams[im.stream]->metadata;
  auto tag = [&](const char* key) -> std::string {
    const AVDictionaryEntry* e = av_dict_get(tags, key, nullptr, 0);
    return e ? e->value : "";
  };
  if (const std::string layout = tag("PVCAP_LAYOUT"); !layout.empty()) {
    if (!is_bayer_planes_layout(layout))
      return Error{
          fmt::format("{}: picture layout '{}' is not one this pvcap reads (update pvcap)", path.string(), layout)};
    r->layout_ = layout;
    r->bayer_format_ = tag("PVCAP_BAYER_FORMAT");
    const std::string depth = tag("PVCAP_BIT_DEPTH");
    r->bit_depth_ = depth.size() == 1 || depth.size() == 2 ? std::atoi(depth.c_str()) : 0;
    if (r->bayer_format_.rfind("Bayer", 0) != 0 || r->bit_depth_ < 8 || r->bit_depth_ > 16)
      return Error{fmt::format("{}: raw video of '{}' at {} bits is not one this pvcap reads", path.string(),
                               r->bayer_format_, depth)};
    auto order = pvcap::plane_order(layout, r->bayer_format_);
    if (!order) return Error{fmt::format("{}: {}", path.string(), order.error().message)};
    r->order_ = order.value();
  }
  const AVCodecDescriptor* descriptor = avcodec_descriptor_get(codec->id);
  im.intra_only = descriptor && (descriptor->props & AV_CODEC_PROP_INTRA_ONLY) != 0;
  im.dec.ptr = avcodec_alloc_context3(codec);
  avcodec_parameters_to_context(im.dec.ptr, im.fmt.ptr->streams[im.stream]->codecpar);
  // Slice threads: the store writes several slices per frame, so one frame decodes on two cores
  // (frame threads would add a frame of delay to every random access).
  im.dec.ptr->thread_count = 2;
  im.dec.ptr->thread_type = FF_THREAD_SLICE;
  r->stacked_height_ = im.dec.ptr->height;
  if (r->raw() && (r->stacked_height_ <= 0 || r->stacked_height_ % 4 != 0))
    return Error{fmt::format("{}: a raw video's picture must stack four planes", path.string())};
  // HuffYUV codes a grey picture's rows in order, each from the one before, and stops at the height
  // it is told: told 3/4 of it, it decodes the first three planes exactly and skips the fourth (a
  // second green in the green-last layout). Other codecs split a picture into slices by its height.
  r->three_planes_possible_ = r->raw() && r->bit_depth_ == 8 && r->layout_ == kBayerPlanesGreenLastLayout &&
                              (codec->id == AV_CODEC_ID_FFVHUFF || codec->id == AV_CODEC_ID_HUFFYUV);
  r->three_planes_ = options.half_size_colour_only && r->three_planes_possible_;
  if (r->three_planes_) {
    im.dec.ptr->height = r->stacked_height_ / 4 * 3;
    r->demosaic_ = Demosaic::HalfSize;
  }
  if (avcodec_open2(im.dec.ptr, codec, nullptr) < 0)
    return Error{fmt::format("{}: cannot open decoder", path.string())};
  im.frame.ptr = av_frame_alloc();
  im.packet.ptr = av_packet_alloc();
  return r;
}

VideoReader::~VideoReader() = default;
int VideoReader::width() const { return raw() ? impl_->dec.ptr->width * 2 : impl_->dec.ptr->width; }
int VideoReader::height() const { return raw() ? stacked_height_ / 2 : impl_->dec.ptr->height; }

Result<bool> VideoReader::next(cv::Mat& bgr, std::int64_t& pts_ms) {
  const FfmpegLogQuiet quiet;
  auto more = decode_next(pts_ms);
  if (more && more.value())
    if (Status s = to_bgr(bgr); !s.ok()) return s.error();
  return more;
}

namespace {
// A raw video's decoded frame as the stored picture (the planes stacked), viewing the frame.
Result<cv::Mat> stored_picture(const AVFrame* f, int bit_depth, const std::filesystem::path& path) {
  // The decoder says what a picture is only once it has decoded one. H.264's decoder hands a grey
  // (4:0:0) picture out as 4:2:0 with blank chroma: its first plane is the grey picture.
  const bool grey8 =
      f->format == AV_PIX_FMT_GRAY8 || f->format == AV_PIX_FMT_YUV420P || f->format == AV_PIX_FMT_YUVJ420P;
  const bool grey16 = f->format == AV_PIX_FMT_GRAY16LE;
  if (!(bit_depth > 8 ? grey16 : grey8))
    return Error{fmt::format("{}: a raw video's pictures must be {}-bit grey", path.string(), bit_depth > 8 ? 16 : 8)};
  return cv::Mat(f->height, f->width, grey16 ? CV_16UC1 : CV_8UC1, f->data[0], std::size_t(f->linesize[0]));
}
}  // namespace

Result<bool> VideoReader::next_stored(cv::Mat& picture, std::int64_t& pts_ms, bool& key) {
  if (!raw()) return Error{fmt::format("{}: a colour video keeps no stored picture to check", path_.string())};
  if (three_planes_)
    return Error{fmt::format("{}: opened for half-size colour images only: no stored picture", path_.string())};
  const FfmpegLogQuiet quiet;
  auto more = decode_next(pts_ms);
  if (!more || !more.value()) return more;
  auto p = stored_picture(impl_->frame.ptr, bit_depth_, path_);
  if (!p) return p.error();
  picture = p.value();
  key = impl_->frame.ptr->key_frame != 0;
  return true;
}

std::optional<std::uint32_t> VideoReader::decoded_picture_crc() const {
  if (!raw() || three_planes_ || last_pts_ms_ == INT64_MIN || !impl_->frame.ptr->data[0]) return std::nullopt;
  auto p = stored_picture(impl_->frame.ptr, bit_depth_, path_);
  if (!p) return std::nullopt;
  return picture_crc(p.value());
}

Status VideoReader::to_mosaic(cv::Mat& mosaic) {
  if (three_planes_)
    return Error{fmt::format("{}: opened for half-size colour images only: no mosaic", path_.string())};
  auto planes = stored_picture(impl_->frame.ptr, bit_depth_, path_);
  if (!planes) return planes.error();
  if (planes.value().rows % 4 != 0 || planes.value().cols <= 0)
    return Error{fmt::format("{}: a raw video's pictures must hold four planes stacked", path_.string())};
  unpack_bayer_planes(planes.value(), mosaic, order_);
  return {};
}

Status VideoReader::to_bgr(cv::Mat& bgr) {
  if (Status s = convert_to_bgr(bgr); !s.ok()) return s;
  if (!image_size_.empty() && bgr.size() != image_size_) {
    cv::Mat scaled = impl_->images.acquire(image_size_.height, image_size_.width, CV_8UC3);
    cv::resize(bgr, scaled, image_size_, 0, 0, cv::INTER_LINEAR);
    bgr = scaled;
  }
  return {};
}

Status VideoReader::convert_to_bgr(cv::Mat& bgr) {
  Impl& im = *impl_;
  if (raw() && demosaic_ == Demosaic::HalfSize && bit_depth_ == 8 && im.frame.ptr->format == AV_PIX_FMT_GRAY8) {
    // The decoded picture already holds the planes (three of them when the decoder stopped before
    // the second green): no mosaic in between.
    const AVFrame* f = im.frame.ptr;
    const int h = stacked_height_ / 4;
    const cv::Mat stacked(f->height, f->width, CV_8UC1, f->data[0], std::size_t(f->linesize[0]));
    cv::Mat planes[4];  // by cell
    for (int k = 0; k < 4; ++k)
      if ((k + 1) * h <= f->height) planes[order_[std::size_t(k)]] = stacked.rowRange(k * h, (k + 1) * h);
    const cv::Size size = image_size_.empty() ? cv::Size(f->width, h) : image_size_;
    bgr = im.images.acquire(size.height, size.width, CV_8UC3);
    if (Status s = scaled_half_size_from_planes(planes, bayer_format_, size, bgr); !s.ok())
      return Error{fmt::format("{}: {}", path_.string(), s.error().message)};
    return {};
  }
  if (raw()) {
    if (Status s = to_mosaic(im.mosaic); !s.ok()) return s;
    bgr = im.images.acquire(im.mosaic.rows, im.mosaic.cols, CV_8UC3);
    cv::Mat& colour = bit_depth_ > 8 ? im.bgr16 : bgr;
    if (Status s = debayer(im.mosaic, bayer_format_, demosaic_, colour); !s.ok())
      return Error{fmt::format("{}: {}", path_.string(), s.error().message)};
    // Colour images are 8-bit: the top 8 of the sensor's bits (the mosaic keeps them all).
    if (bit_depth_ > 8) im.bgr16.convertTo(bgr, CV_8U, 1.0 / double(1 << (bit_depth_ - 8)));
    return {};
  }
  bgr = im.images.acquire(im.frame.ptr->height, im.frame.ptr->width, CV_8UC3);
  if (demosaic_ == Demosaic::HalfSize) {  // a colour video asked for half size: converted, then halved
    demosaic_ = Demosaic::Bilinear;
    Status s = convert_to_bgr(bgr);
    demosaic_ = Demosaic::HalfSize;
    // Straight to the image size when one is set: one resize, not two.
    if (s.ok()) cv::resize(cv::Mat(bgr), bgr, image_size_, 0.5, 0.5, cv::INTER_AREA);
    return s;
  }
  if (im.frame.ptr->format == AV_PIX_FMT_YUV444P && im.frame.ptr->color_range != AVCOL_RANGE_JPEG &&
      im.frame.ptr->colorspace != AVCOL_SPC_BT709) {
    // The store's default format, converted here (faster than swscale for this pair): the inverse of
    // the writer's BT.601 limited-range conversion.
    static const cv::Matx34f kYCbCrToBgr(1.164383f, 2.017232f, 0.f, -276.836f,         //
                                         1.164383f, -0.391762f, -0.812968f, 135.576f,  //
                                         1.164383f, 0.f, 1.596027f, -222.921f);
    std::vector<cv::Mat> planes;
    for (int p = 0; p < 3; ++p)
      planes.emplace_back(im.frame.ptr->height, im.frame.ptr->width, CV_8UC1, im.frame.ptr->data[p],
                          std::size_t(im.frame.ptr->linesize[p]));
    cv::merge(planes, im.ycbcr);
    cv::transform(im.ycbcr, bgr, kYCbCrToBgr);
    return {};
  }
  im.sws.ptr = sws_getCachedContext(im.sws.ptr, im.frame.ptr->width, im.frame.ptr->height,
                                    AVPixelFormat(im.frame.ptr->format), im.frame.ptr->width, im.frame.ptr->height,
                                    AV_PIX_FMT_BGR24, SWS_POINT, nullptr, nullptr, nullptr);
  std::uint8_t* dst[1] = {bgr.data};
  const int dst_stride[1] = {int(bgr.step[0])};
  sws_scale(im.sws.ptr, im.frame.ptr->data, im.frame.ptr->linesize, 0, im.frame.ptr->height, dst, dst_stride);
  return {};
}

// Decodes the next frame into the decoder's own frame, without converting it.
Result<bool> VideoReader::decode_next(std::int64_t& pts_ms, std::int64_t skip_before_ms) {
  Impl& im = *impl_;
  for (;;) {
    const int rc = avcodec_receive_frame(im.dec.ptr, im.frame.ptr);
    if (rc == 0) {
      const AVRational tb = im.fmt.ptr->streams[im.stream]->time_base;
      pts_ms = av_rescale_q(im.frame.ptr->best_effort_timestamp, tb, AVRational{1, 1000});
      last_pts_ms_ = pts_ms;
      ++frames_decoded_;
      return true;
    }
    if (rc == AVERROR_EOF) return false;
    if (rc != AVERROR(EAGAIN)) return Error{fmt::format("{}: decoding failed", path_.string())};
    if (im.draining) return false;
    // Feed the decoder.
    for (;;) {
      const int rr = av_read_frame(im.fmt.ptr, im.packet.ptr);
      // The disk failed a read: said as such, never taken for the file's end (verify would call the
      // frames after it missing, the reader would hand out fewer).
      if (rr == AVERROR(EIO) || (im.fmt.ptr->pb && im.fmt.ptr->pb->error == AVERROR(EIO)))
        return Error{fmt::format("{}: cannot be read: {}", path_.string(), av::error(AVERROR(EIO))), true};
      if (rr < 0) {  // end of file (or a truncated tail): drain what is buffered
        im.draining = true;
        avcodec_send_packet(im.dec.ptr, nullptr);
        break;
      }
      const AVPacket* pkt = im.packet.ptr;
      if (pkt->stream_index == im.stream && im.intra_only && skip_before_ms != INT64_MIN &&
          pkt->pts != AV_NOPTS_VALUE &&
          av_rescale_q(pkt->pts, im.fmt.ptr->streams[im.stream]->time_base, AVRational{1, 1000}) < skip_before_ms) {
        av_packet_unref(im.packet.ptr);  // a frame before the one asked for, which nothing refers to
        continue;
      }
      if (pkt->stream_index == im.stream) {
        const int sr = avcodec_send_packet(im.dec.ptr, im.packet.ptr);
        av_packet_unref(im.packet.ptr);
        if (sr < 0 && sr != AVERROR(EAGAIN)) return Error{fmt::format("{}: corrupt video packet", path_.string())};
        break;
      }
      av_packet_unref(im.packet.ptr);
    }
  }
}

Result<bool> VideoReader::read_at(std::int64_t pts_ms, cv::Mat& bgr, std::int64_t tolerance_ms) {
  return seek_and_convert(pts_ms, bgr, tolerance_ms, false);
}

Result<bool> VideoReader::read_raw_at(std::int64_t pts_ms, cv::Mat& mosaic, std::int64_t tolerance_ms) {
  if (!raw()) return Error{fmt::format("{}: a colour video (stored debayered) holds no sensor mosaic", path_.string())};
  return seek_and_convert(pts_ms, mosaic, tolerance_ms, true);
}

Result<bool> VideoReader::seek_and_convert(std::int64_t pts_ms, cv::Mat& out, std::int64_t tolerance_ms,
                                           bool as_mosaic) {
  const FfmpegLogQuiet quiet;
  Impl& im = *impl_;
  const AVRational tb = im.fmt.ptr->streams[im.stream]->time_base;
  auto seek = [&](std::int64_t ts, int flags) {
    if (av_seek_frame(im.fmt.ptr, im.stream, ts, flags) < 0) return false;
    avcodec_flush_buffers(im.dec.ptr);
    im.draining = false;
    last_pts_ms_ = INT64_MIN;
    return true;
  };
  auto decode_up_to = [&]() -> Result<bool> {
    std::int64_t at = 0;
    // Frames before the one asked for are decoded (they are its references), not converted; an
    // intra-only video's are not even decoded (a calibration reading every third sample decoded all).
    for (;;) {
      auto more = decode_next(at, pts_ms - tolerance_ms);
      if (!more) return more.error();
      if (!more.value()) return false;
      if (at >= pts_ms - tolerance_ms) {
        if (at > pts_ms + tolerance_ms) return false;
        if (as_mosaic) {
          if (Status s = to_mosaic(out); !s.ok()) return s.error();
          return true;
        }
        if (Status s = to_bgr(out); !s.ok()) return s.error();
        return true;
      }
    }
  };
  // Ahead within about a GOP of where decoding stands: read on. Anything else: seek.
  const bool ahead = last_pts_ms_ != INT64_MIN && pts_ms > last_pts_ms_ + tolerance_ms &&
                     pts_ms - last_pts_ms_ <= 1000 && !im.draining;
  if (ahead) return decode_up_to();
  if (seek(av_rescale_q(pts_ms - tolerance_ms, AVRational{1, 1000}, tb), AVSEEK_FLAG_BACKWARD)) {
    auto found = decode_up_to();
    if (!found || found.value()) return found;
  }
  // A file without an index (cut by a crash) may seek past the frame: read it from the start.
  if (!seek(INT64_MIN, AVSEEK_FLAG_BACKWARD | AVSEEK_FLAG_ANY))
    return Error{fmt::format("{}: cannot seek to {} ms", path_.string(), pts_ms)};
  return decode_up_to();
}

Result<bool> VideoReader::next_packet(std::int64_t& pts_ms, bool& key) {
  const FfmpegLogQuiet quiet;
  Impl& im = *impl_;
  for (;;) {
    const int rr = av_read_frame(im.fmt.ptr, im.packet.ptr);
    if (rr == AVERROR(EIO) || (im.fmt.ptr->pb && im.fmt.ptr->pb->error == AVERROR(EIO)))
      return Error{fmt::format("{}: cannot be read: {}", path_.string(), av::error(AVERROR(EIO))), true};
    if (rr == AVERROR_EOF) return false;
    if (rr < 0) return Error{fmt::format("{}: unreadable after the last good frame (truncated?)", path_.string())};
    if (im.packet.ptr->stream_index != im.stream) {
      av_packet_unref(im.packet.ptr);
      continue;
    }
    const AVRational tb = im.fmt.ptr->streams[im.stream]->time_base;
    pts_ms = av_rescale_q(im.packet.ptr->pts, tb, AVRational{1, 1000});
    key = (im.packet.ptr->flags & AV_PKT_FLAG_KEY) != 0;
    av_packet_unref(im.packet.ptr);
    return true;
  }
}

}  // namespace pvcap
