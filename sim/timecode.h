#pragma once
// A machine-readable timecode drawn into every simulated image: the true
// capture time and the frame id, so a test can read the stored video and
// measure, frame by frame, what the pipeline did with time.
//
// Layout: 2 rows x 48 square cells starting one cell from the top-left corner;
// a cell is black (0) or white (1). Bits, most significant first: 64 bits true
// time (ns, CLOCK_MONOTONIC), 16 bits frame id, 16 bits CRC-16/CCITT of the
// preceding 10 bytes. Cells are large (width/64 px) and even-sized so they
// survive Bayer mosaicking, debayering and lossy video coding.
#include <cstdint>
#include <optional>

#include <opencv2/core.hpp>

namespace pvcap::sim {

struct Timecode {
  std::int64_t true_ns = 0;
  std::uint16_t frame_id = 0;
  bool operator==(const Timecode&) const = default;
};

int timecode_cell_px(int image_width);
std::uint16_t crc16_ccitt(const std::uint8_t* data, std::size_t n);

// Draws into an 8-bit single-channel image (a Bayer mosaic or Mono8): all
// pixels of a cell get the same value, whatever the colour filter.
void draw_timecode(cv::Mat& mosaic, const Timecode& tc);
// Reads from an 8-bit BGR or grey image; empty when no valid timecode is there.
std::optional<Timecode> read_timecode(const cv::Mat& image);

// A column of cells down the right edge whose pattern depends on the frame id, so
// that a frame assembled partly from an older frame's bytes (missing packets,
// stale buffer) shows it wherever the stale part is.
void draw_frame_stripe(cv::Mat& mosaic, std::uint16_t frame_id);
// How many stripe cells disagree with `frame_id`'s pattern (0 for an intact frame).
int frame_stripe_mismatches(const cv::Mat& image, std::uint16_t frame_id);

}  // namespace pvcap::sim
