#include "storage/video/video_reader.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/imgutils.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "core/frame_pool.h"
#include "storage/video/av_handles.h"
#include "storage/video/av_log.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/bayer_tiles.h"
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
  // A tiled raw video (storage/video/bayer_tiles.h): each tile its own stream, decoded by a decoder
  // of its own or one it shares.
  struct Decoder {
    av::CodecContext dec;
    av::Frame frame;
  };
  struct Tile {
    int stream = -1;
    std::size_t decoder = 0;  // into decoders
  };
  std::vector<Tile> tiles;       // empty: one stream holds the whole picture
  // An intra-only codec's tiles of one description (HuffYUV's tables are in it) share a decoder:
  // each holds its tables and buffers, ~0.5 MB, and a reader keeps several videos open.
  std::vector<Decoder> decoders;
  std::vector<int> stream_tile;  // stream index -> tile (-1: not a tile)
  TileGrid grid;
  std::vector<char> wanted;      // the tiles the next read decodes
  std::vector<char> seen;        // the tiles of the frame being read whose packet came
  int seen_count = 0;
  std::int64_t group_pts = INT64_MIN;
  cv::Mat planes;                // the decoded tiles of the last frame put back in place
  bool planes_whole = false;     // every tile of the last frame is in `planes`
  bool key = false;              // the last frame's first tile was a key frame
  int picture_format = -1;       // what the tiles decode as
  bool tiled() const { return !tiles.empty(); }
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
  if (const std::string tiles = tag("PVCAP_TILES"); !tiles.empty() && r->raw()) {
    if (Status st = open_tiles(*r, tiles, tag("PVCAP_SIZE"), codec, options); !st.ok()) return st.error();
    return r;
  }
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
int VideoReader::width() const {
  if (impl_->tiled()) return impl_->grid.mosaic.width;
  return raw() ? impl_->dec.ptr->width * 2 : impl_->dec.ptr->width;
}
int VideoReader::height() const { return raw() ? stacked_height_ / 2 : impl_->dec.ptr->height; }
int VideoReader::tiles() const { return impl_->tiled() ? impl_->grid.count() : 1; }
int VideoReader::tile_cols() const { return impl_->tiled() ? impl_->grid.cols : 1; }
int VideoReader::tile_rows() const { return impl_->tiled() ? impl_->grid.rows : 1; }
int VideoReader::tile_decoders() const { return int(impl_->decoders.size()); }

Status VideoReader::open_tiles(VideoReader& r, const std::string& tiles, const std::string& size, const AVCodec* codec,
                               const Options& options) {
  Impl& im = *r.impl_;
  const std::string where = r.path_.string();
  int w = 0, h = 0;
  if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2 || w <= 0 || h <= 0)
    return Error{fmt::format("{}: a tiled raw video without its mosaic's size (PVCAP_SIZE '{}')", where, size)};
  auto grid = parse_tile_grid(tiles, {w, h});
  if (!grid) return Error{fmt::format("{}: {}", where, grid.error().message)};
  im.grid = grid.value();
  im.tiles.resize(std::size_t(im.grid.count()));
  im.stream_tile.assign(im.fmt.ptr->nb_streams, -1);
  for (unsigned i = 0; i < im.fmt.ptr->nb_streams; ++i) {
    const AVDictionaryEntry* e = av_dict_get(im.fmt.ptr->streams[i]->metadata, "PVCAP_TILE", nullptr, 0);
    const int t = e ? std::atoi(e->value) : -1;
    if (t < 0 || t >= im.grid.count() || im.tiles[std::size_t(t)].stream >= 0)
      return Error{fmt::format("{}: stream {} is not one tile of the {} grid", where, i, tiles)};
    im.tiles[std::size_t(t)].stream = int(i);
    im.stream_tile[i] = t;
  }
  const cv::Size picture = bayer_planes_size(im.grid.tile_size());
  r.stacked_height_ = h * 2;
  r.three_planes_possible_ = r.bit_depth_ == 8 && r.layout_ == kBayerPlanesGreenLastLayout &&
                             (codec->id == AV_CODEC_ID_FFVHUFF || codec->id == AV_CODEC_ID_HUFFYUV);
  r.three_planes_ = options.half_size_colour_only && r.three_planes_possible_;
  if (r.three_planes_) r.demosaic_ = Demosaic::HalfSize;
  for (std::size_t t = 0; t < im.tiles.size(); ++t) {
    Impl::Tile& tile = im.tiles[t];
    if (tile.stream < 0) return Error{fmt::format("{}: tile {} of the {} grid has no stream", where, t, tiles)};
    const AVCodecParameters* par = im.fmt.ptr->streams[tile.stream]->codecpar;
    if (par->codec_id != codec->id || par->width != picture.width || par->height != picture.height)
      return Error{fmt::format("{}: tile {} is not a {}x{} picture of the first tile's codec", where, t, picture.width,
                               picture.height)};
    if (im.intra_only) {
      const auto same = [&](const Impl::Tile& other) {
        const AVCodecParameters* o = im.fmt.ptr->streams[other.stream]->codecpar;
        return o->extradata_size == par->extradata_size &&
               (par->extradata_size == 0 || std::memcmp(o->extradata, par->extradata, std::size_t(par->extradata_size)) == 0);
      };
      const auto earlier = std::find_if(im.tiles.begin(), im.tiles.begin() + std::ptrdiff_t(t), same);
      if (earlier != im.tiles.begin() + std::ptrdiff_t(t)) {
        tile.decoder = earlier->decoder;
        continue;
      }
    }
    tile.decoder = im.decoders.size();
    Impl::Decoder& d = im.decoders.emplace_back();
    d.dec.ptr = avcodec_alloc_context3(codec);
    avcodec_parameters_to_context(d.dec.ptr, par);
    d.dec.ptr->thread_count = 1;  // a tile is small; the read decodes several
    d.dec.ptr->flags |= AV_CODEC_FLAG_LOW_DELAY;
    if (r.three_planes_) d.dec.ptr->height = picture.height / 4 * 3;
    if (avcodec_open2(d.dec.ptr, codec, nullptr) < 0)
      return Error{fmt::format("{}: cannot open the decoder of tile {}", where, t)};
    d.frame.ptr = av_frame_alloc();
  }
  im.stream = im.tiles[0].stream;
  im.wanted.assign(im.tiles.size(), 1);
  im.seen.assign(im.tiles.size(), 0);
  im.packet.ptr = av_packet_alloc();
  return {};
}

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

Result<cv::Mat> VideoReader::picture() const {
  const Impl& im = *impl_;
  if (!im.tiled()) return stored_picture(im.frame.ptr, bit_depth_, path_);
  const int f = im.picture_format;  // H.264 hands a grey picture out as 4:2:0, its first plane the picture
  const bool grey8 = f == AV_PIX_FMT_GRAY8 || f == AV_PIX_FMT_YUV420P || f == AV_PIX_FMT_YUVJ420P;
  if (!(bit_depth_ > 8 ? f == AV_PIX_FMT_GRAY16LE : grey8))
    return Error{fmt::format("{}: a raw video's pictures must be {}-bit grey", path_.string(), bit_depth_ > 8 ? 16 : 8)};
  return three_planes_ ? im.planes.rowRange(0, stacked_height_ / 4 * 3) : im.planes;
}

Result<bool> VideoReader::next_stored(cv::Mat& picture, std::int64_t& pts_ms, bool& key) {
  if (!raw()) return Error{fmt::format("{}: a colour video keeps no stored picture to check", path_.string())};
  if (three_planes_)
    return Error{fmt::format("{}: opened for half-size colour images only: no stored picture", path_.string())};
  const FfmpegLogQuiet quiet;
  auto more = decode_next(pts_ms);
  if (!more || !more.value()) return more;
  auto p = this->picture();
  if (!p) return p.error();
  picture = p.value();
  key = impl_->tiled() ? impl_->key : impl_->frame.ptr->key_frame != 0;
  return true;
}

std::optional<std::uint32_t> VideoReader::decoded_picture_crc() const {
  if (!raw() || three_planes_ || last_pts_ms_ == INT64_MIN) return std::nullopt;
  if (impl_->tiled() ? !impl_->planes_whole : !impl_->frame.ptr->data[0]) return std::nullopt;
  auto p = picture();
  if (!p) return std::nullopt;
  return picture_crc(p.value());
}

Status VideoReader::to_mosaic(cv::Mat& mosaic) {
  if (three_planes_)
    return Error{fmt::format("{}: opened for half-size colour images only: no mosaic", path_.string())};
  auto planes = picture();
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
  const bool grey8 = im.tiled() ? im.picture_format == AV_PIX_FMT_GRAY8 : im.frame.ptr->format == AV_PIX_FMT_GRAY8;
  if (raw() && demosaic_ == Demosaic::HalfSize && bit_depth_ == 8 && grey8) {
    // The decoded picture already holds the planes (three of them when the decoder stopped before
    // the second green): no mosaic in between.
    auto picture = this->picture();
    if (!picture) return picture.error();
    const cv::Mat& stacked = picture.value();
    const int h = stacked_height_ / 4;
    cv::Mat planes[4];  // by cell
    for (int k = 0; k < 4; ++k)
      if ((k + 1) * h <= stacked.rows) planes[order_[std::size_t(k)]] = stacked.rowRange(k * h, (k + 1) * h);
    const cv::Size size = image_size_.empty() ? cv::Size(stacked.cols, h) : image_size_;
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
  if (im.tiled()) return decode_next_tiles(pts_ms, skip_before_ms, true);
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

// A tiled video's next frame: its tiles' packets (the writer writes a frame's tiles one after
// another), the wanted ones decoded and put back in place in `planes`. A frame cut short (a crash
// between its tiles) is passed over, as is a frame stamped before `skip_before_ms` (intra-only
// codecs). `decode` false: the packets are counted, not decoded.
Result<bool> VideoReader::decode_next_tiles(std::int64_t& pts_ms, std::int64_t skip_before_ms, bool decode) {
  Impl& im = *impl_;
  const int count = im.grid.count();
  for (;;) {
    const int rr = av_read_frame(im.fmt.ptr, im.packet.ptr);
    if (rr == AVERROR(EIO) || (im.fmt.ptr->pb && im.fmt.ptr->pb->error == AVERROR(EIO)))
      return Error{fmt::format("{}: cannot be read: {}", path_.string(), av::error(AVERROR(EIO))), true};
    if (rr < 0) {
      im.draining = true;
      return false;  // the end (or a cut tail): a frame without all its tiles is not one
    }
    AVPacket* pkt = im.packet.ptr;
    const int t = pkt->stream_index >= 0 && std::size_t(pkt->stream_index) < im.stream_tile.size()
                      ? im.stream_tile[std::size_t(pkt->stream_index)]
                      : -1;
    if (t < 0 || pkt->pts == AV_NOPTS_VALUE) {
      av_packet_unref(pkt);
      continue;
    }
    const std::int64_t at =
        av_rescale_q(pkt->pts, im.fmt.ptr->streams[pkt->stream_index]->time_base, AVRational{1, 1000});
    if (at != im.group_pts) {  // a new frame begins
      im.group_pts = at;
      std::fill(im.seen.begin(), im.seen.end(), 0);
      im.seen_count = 0;
    }
    if (im.seen[std::size_t(t)]) {
      av_packet_unref(pkt);
      continue;
    }
    im.seen[std::size_t(t)] = 1;
    ++im.seen_count;
    if (t == 0) im.key = (pkt->flags & AV_PKT_FLAG_KEY) != 0;
    const bool skipped = im.intra_only && skip_before_ms != INT64_MIN && at < skip_before_ms;
    if (decode && !skipped && im.wanted[std::size_t(t)]) {
      Impl::Decoder& tile = im.decoders[im.tiles[std::size_t(t)].decoder];
      const int sr = avcodec_send_packet(tile.dec.ptr, pkt);
      av_packet_unref(pkt);
      if (sr < 0) return Error{fmt::format("{}: corrupt video packet (tile {})", path_.string(), t)};
      if (avcodec_receive_frame(tile.dec.ptr, tile.frame.ptr) < 0)
        return Error{fmt::format("{}: tile {} at {} ms did not decode", path_.string(), t, at)};
      im.picture_format = tile.frame.ptr->format;
      ++tiles_decoded_;
      const cv::Mat picture(tile.frame.ptr->height, tile.frame.ptr->width, bit_depth_ > 8 ? CV_16UC1 : CV_8UC1,
                            tile.frame.ptr->data[0], std::size_t(tile.frame.ptr->linesize[0]));
      copy_tile_to_planes(picture, im.grid, t, im.planes);
    } else {
      av_packet_unref(pkt);
    }
    if (im.seen_count < count || skipped) continue;
    pts_ms = at;
    last_pts_ms_ = at;
    if (decode) {
      ++frames_decoded_;
      im.planes_whole = std::all_of(im.wanted.begin(), im.wanted.end(), [](char w) { return w != 0; });
    }
    return true;
  }
}

Result<bool> VideoReader::read_raw_region_at(std::int64_t pts_ms, cv::Rect box, cv::Mat& mosaic,
                                             std::int64_t tolerance_ms) {
  if (!raw()) return Error{fmt::format("{}: a colour video (stored debayered) holds no sensor mosaic", path_.string())};
  if (box.x % 2 || box.y % 2 || box.width % 2 || box.height % 2 || box.empty() ||
      (box & cv::Rect(0, 0, width(), height())) != box)
    return Error{fmt::format("{}: ({}, {}, {}, {}) is not a region of whole Bayer cells inside the {}x{} mosaic",
                             path_.string(), box.x, box.y, box.width, box.height, width(), height())};
  return seek_and_convert(pts_ms, mosaic, tolerance_ms, Convert::Region, box);
}

Status VideoReader::to_mosaic_region(cv::Rect box, cv::Mat& mosaic) {
  if (three_planes_)
    return Error{fmt::format("{}: opened for half-size colour images only: no mosaic", path_.string())};
  auto planes = picture();
  if (!planes) return planes.error();
  const cv::Mat& p = planes.value();
  const int plane_height = stacked_height_ / 4;
  // The box's part of each plane, stacked as a mosaic of the box's size would stack them.
  cv::Mat stacked(box.height * 2, box.width / 2, p.type());
  for (int k = 0; k < 4; ++k) {
    cv::Mat dst = stacked.rowRange(k * box.height / 2, (k + 1) * box.height / 2);
    p(cv::Rect(box.x / 2, k * plane_height + box.y / 2, box.width / 2, box.height / 2)).copyTo(dst);
  }
  unpack_bayer_planes(stacked, mosaic, order_);
  return {};
}

Result<bool> VideoReader::read_at(std::int64_t pts_ms, cv::Mat& bgr, std::int64_t tolerance_ms) {
  return seek_and_convert(pts_ms, bgr, tolerance_ms, Convert::Bgr);
}

Result<bool> VideoReader::read_raw_at(std::int64_t pts_ms, cv::Mat& mosaic, std::int64_t tolerance_ms) {
  if (!raw()) return Error{fmt::format("{}: a colour video (stored debayered) holds no sensor mosaic", path_.string())};
  return seek_and_convert(pts_ms, mosaic, tolerance_ms, Convert::Mosaic);
}

Result<bool> VideoReader::seek_and_convert(std::int64_t pts_ms, cv::Mat& out, std::int64_t tolerance_ms,
                                           Convert what, cv::Rect region) {
  const FfmpegLogQuiet quiet;
  Impl& im = *impl_;
  if (im.tiled()) {
    // A region decodes the tiles under it; a video whose frames refer to earlier ones (a compacted
    // GOP) decodes every tile, or the tiles left out would lose their references.
    std::fill(im.wanted.begin(), im.wanted.end(), what == Convert::Region && im.intra_only ? 0 : 1);
    if (what == Convert::Region && im.intra_only)
      for (const int t : im.grid.covering(region)) im.wanted[std::size_t(t)] = 1;
  }
  const AVRational tb = im.fmt.ptr->streams[im.stream]->time_base;
  auto seek = [&](std::int64_t ts, int flags) {
    if (av_seek_frame(im.fmt.ptr, im.stream, ts, flags) < 0) return false;
    if (im.tiled()) {
      for (Impl::Decoder& d : im.decoders) avcodec_flush_buffers(d.dec.ptr);
      im.group_pts = INT64_MIN;
    } else {
      avcodec_flush_buffers(im.dec.ptr);
    }
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
        if (what == Convert::Region) {
          if (Status s = to_mosaic_region(region, out); !s.ok()) return s.error();
          return true;
        }
        if (what == Convert::Mosaic) {
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
  if (im.tiled()) {  // a frame is its tiles' packets, all of them
    auto more = decode_next_tiles(pts_ms, INT64_MIN, false);
    key = im.key;
    return more;
  }
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
