#pragma once
// Reads a session video back, frame by frame, as BGR images with their
// timestamps (the libav* edge on the reading side). A raw video (the sensor's Bayer mosaic,
// stored losslessly) is demosaiced as it is read, or handed out as the mosaic itself.
#include <climits>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "codec/demosaic.h"
#include "core/result.h"
#include "storage/video/bayer_planes.h"

struct AVCodec;

namespace pvcap {

class VideoReader {
 public:
  struct Options {
    // The reader will only be asked for half-size colour images (a viewer's: the replay's views).
    // An 8-bit raw video whose layout stacks its second green last, coded with HuffYUV, then
    // decodes its first three planes only (a quarter less work; the half-size green is the first
    // green alone, not the mean of both). Such a reader gives no stored picture, mosaic or
    // checksum. Other videos read as without it.
    bool half_size_colour_only = false;
  };
  static Result<std::unique_ptr<VideoReader>> open(const std::filesystem::path& path, const Options& options);
  static Result<std::unique_ptr<VideoReader>> open(const std::filesystem::path& path) { return open(path, Options{}); }
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  // The next frame in file order; false at the end. `pts_ms` is its timestamp.
  Result<bool> next(cv::Mat& bgr, std::int64_t& pts_ms);
  // A raw video's next frame as stored (its planes stacked, as storage/video/frame_checksum.h checksums
  // it), in file order; false at the end. `picture` views the decoder's memory until the next call.
  // An Error for a colour video. Do not mix with next() or next_packet().
  Result<bool> next_stored(cv::Mat& picture, std::int64_t& pts_ms, bool& key);
  // A raw video: the CRC-32 of the stored picture last decoded (by any read), as
  // storage/video/frame_checksum.h takes it at capture; nullopt for a colour video or before a read.
  std::optional<std::uint32_t> decoded_picture_crc() const;
  // Frames decoded so far by any read (what random access costs: an intra-only video decodes only
  // the frames asked for).
  std::uint64_t frames_decoded() const { return frames_decoded_; }
  // Tiles decoded so far (a tiled raw video; a region's read decodes only the tiles under it).
  std::uint64_t tiles_decoded() const { return tiles_decoded_; }
  // Without decoding: the next packet of the video stream (one per frame here: no B-frames),
  // its timestamp and whether it is a key frame; false at the end. Do not mix with next().
  Result<bool> next_packet(std::int64_t& pts_ms, bool& key);
  // Random access: the frame whose timestamp is within `tolerance_ms` of `pts_ms`, decoded. Reads on
  // without seeking when that frame lies ahead in the current GOP (sequential use stays cheap),
  // otherwise seeks to the key frame before it (at most one GOP to decode). False when the
  // file holds no such frame.
  Result<bool> read_at(std::int64_t pts_ms, cv::Mat& bgr, std::int64_t tolerance_ms = 1);
  // The same frame as the sensor's mosaic (CV_8UC1; CV_16UC1 above 8 bits), exactly as captured. An
  // Error for a colour video. (Colour images are always 8-bit: a deeper mosaic's top 8 bits.)
  Result<bool> read_raw_at(std::int64_t pts_ms, cv::Mat& mosaic, std::int64_t tolerance_ms = 1);
  // A region of the same frame as the sensor's mosaic: `box` in the mosaic's pixels, of whole 2x2
  // cells (even position and size), inside it; `mosaic` is the box's size. A tiled video
  // (storage/video/bayer_tiles.h) decodes only the tiles under the box; another decodes the whole
  // frame. No checksum can be taken of a region (decoded_picture_crc says none).
  Result<bool> read_raw_region_at(std::int64_t pts_ms, cv::Rect box, cv::Mat& mosaic, std::int64_t tolerance_ms = 1);
  // How raw videos become colour (bilinear unless set; colour videos ignore it; a reader that
  // decodes three planes stays at half size).
  void set_demosaic(Demosaic method) {
    if (!three_planes_) demosaic_ = method;
  }
  // Colour images scaled to `size` (bilinear; empty, the default: their own size). A raw video's
  // half-size image is made at that size straight from its planes (codec/demosaic.h).
  void set_image_size(cv::Size size) { image_size_ = size; }
  // The image size (a raw video's mosaic size, not its stacked planes).
  int width() const;
  int height() const;
  // A raw video's Bayer pattern ("BayerRG8"); empty for a colour video.
  const std::string& bayer_format() const { return bayer_format_; }
  bool raw() const { return !bayer_format_.empty(); }
  int bit_depth() const { return bit_depth_; }           // a raw video's bits per sample
  const std::string& layout() const { return layout_; }  // a raw video's plane stacking (storage/video/bayer_planes.h)
  const PlaneOrder& plane_order() const { return order_; }
  // How many tiles a raw video's frames are stored in (1: the whole picture in one stream).
  int tiles() const;
  int tile_cols() const;
  int tile_rows() const;
  // Decoders a tiled video holds open: one for all tiles of an intra-only codec (HuffYUV's tiles
  // share their tables), one per tile otherwise (each keeps its own references).
  int tile_decoders() const;
  // Whether this reader decodes only the first three planes (Options::half_size_colour_only took),
  // and whether the video allows it (so a reader opened without the option can tell).
  bool decodes_three_planes() const { return three_planes_; }
  bool can_decode_three_planes() const { return three_planes_possible_; }

 private:
  VideoReader() = default;
  // `skip_before_ms`: packets stamped earlier are read past, not decoded, where no frame refers to
  // another (intra-only codecs: the raw store's); other codecs decode every frame (references).
  Result<bool> decode_next(std::int64_t& pts_ms, std::int64_t skip_before_ms = INT64_MIN);
  Result<bool> decode_next_tiles(std::int64_t& pts_ms, std::int64_t skip_before_ms, bool decode);
  static Status open_tiles(VideoReader& r, const std::string& tiles, const std::string& size, const AVCodec* codec,
                           const Options& options);
  enum class Convert { Bgr, Mosaic, Region };
  Result<bool> seek_and_convert(std::int64_t pts_ms, cv::Mat& out, std::int64_t tolerance_ms, Convert what,
                                cv::Rect region = {});
  // The stored picture last decoded (the planes stacked; a tiled video's tiles put back in place).
  Result<cv::Mat> picture() const;
  Status to_mosaic_region(cv::Rect box, cv::Mat& mosaic);
  Status to_bgr(cv::Mat& bgr);
  Status convert_to_bgr(cv::Mat& bgr);  // to_bgr before scaling to image_size_
  Status to_mosaic(cv::Mat& mosaic);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::filesystem::path path_;
  std::int64_t last_pts_ms_ = INT64_MIN;  // of the frame next() returned last
  std::uint64_t frames_decoded_ = 0;
  std::uint64_t tiles_decoded_ = 0;
  std::string bayer_format_;
  std::string layout_;
  PlaneOrder order_ = kCellOrder;
  int stacked_height_ = 0;              // a raw video's whole stacked picture, whatever the decoder is told
  bool three_planes_possible_ = false;  // an 8-bit green-last HuffYUV video
  bool three_planes_ = false;           // the decoder stops before the last plane (the second green)
  int bit_depth_ = 8;
  Demosaic demosaic_ = Demosaic::Bilinear;
  cv::Size image_size_;
};

}  // namespace pvcap
