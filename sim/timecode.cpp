#include "sim/timecode.h"

#include <array>

#include <opencv2/imgproc.hpp>

namespace pvcap::sim {

namespace {
constexpr int kCols = 48;
constexpr int kRows = 2;
constexpr int kBits = kCols * kRows;  // 96

std::array<std::uint8_t, 12> pack(const Timecode& tc) {
  std::array<std::uint8_t, 12> b{};
  for (int i = 0; i < 8; ++i) b[i] = std::uint8_t(std::uint64_t(tc.true_ns) >> (56 - 8 * i));
  b[8] = std::uint8_t(tc.frame_id >> 8);
  b[9] = std::uint8_t(tc.frame_id);
  const std::uint16_t crc = crc16_ccitt(b.data(), 10);
  b[10] = std::uint8_t(crc >> 8);
  b[11] = std::uint8_t(crc);
  return b;
}
}  // namespace

std::uint16_t crc16_ccitt(const std::uint8_t* data, std::size_t n) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= std::uint16_t(data[i]) << 8;
    for (int k = 0; k < 8; ++k) crc = (crc & 0x8000) ? std::uint16_t((crc << 1) ^ 0x1021) : std::uint16_t(crc << 1);
  }
  return crc;
}

int timecode_cell_px(int image_width) { return std::max(4, (image_width / 64) & ~1); }

void draw_timecode(cv::Mat& mosaic, const Timecode& tc) {
  CV_Assert(mosaic.type() == CV_8UC1);
  const int c = timecode_cell_px(mosaic.cols);
  const auto bytes = pack(tc);
  for (int bit = 0; bit < kBits; ++bit) {
    const bool on = (bytes[bit / 8] >> (7 - bit % 8)) & 1;
    const int row = bit / kCols, col = bit % kCols;
    const cv::Rect cell((col + 1) * c, (row + 1) * c, c, c);
    if (cell.br().x > mosaic.cols || cell.br().y > mosaic.rows) return;  // image too small to carry it
    mosaic(cell).setTo(on ? 255 : 0);
  }
}

std::optional<Timecode> read_timecode(const cv::Mat& image) {
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else
    grey = image;
  const int c = timecode_cell_px(grey.cols);
  if ((kCols + 1) * c > grey.cols || (kRows + 1) * c > grey.rows) return std::nullopt;
  std::array<std::uint8_t, 12> b{};
  for (int bit = 0; bit < kBits; ++bit) {
    const int row = bit / kCols, col = bit % kCols;
    // Average the cell's centre half, away from edges blurred by debayering and coding.
    const cv::Rect centre((col + 1) * c + c / 4, (row + 1) * c + c / 4, std::max(1, c / 2), std::max(1, c / 2));
    if (cv::mean(grey(centre))[0] >= 128) b[bit / 8] |= std::uint8_t(1u << (7 - bit % 8));
  }
  const std::uint16_t crc = crc16_ccitt(b.data(), 10);
  if (b[10] != std::uint8_t(crc >> 8) || b[11] != std::uint8_t(crc)) return std::nullopt;
  Timecode tc;
  std::uint64_t t = 0;
  for (int i = 0; i < 8; ++i) t = (t << 8) | b[i];
  tc.true_ns = std::int64_t(t);
  tc.frame_id = std::uint16_t((b[8] << 8) | b[9]);
  return tc;
}

namespace {
// splitmix64: non-linear, so two frame ids differ in about half of the cells.
bool stripe_bit(std::uint16_t frame_id, int cell) {
  std::uint64_t z = (std::uint64_t(frame_id) << 16 | std::uint64_t(cell)) + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return (z ^ (z >> 31)) & 1;
}
}  // namespace

void draw_frame_stripe(cv::Mat& mosaic, std::uint16_t frame_id) {
  CV_Assert(mosaic.type() == CV_8UC1);
  const int c = timecode_cell_px(mosaic.cols);
  const int x = mosaic.cols - 2 * c;
  for (int k = 0; (k + 1) * c <= mosaic.rows; ++k)
    mosaic(cv::Rect(x, k * c, c, c)).setTo(stripe_bit(frame_id, k) ? 255 : 0);
}

int frame_stripe_mismatches(const cv::Mat& image, std::uint16_t frame_id) {
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  else
    grey = image;
  const int c = timecode_cell_px(grey.cols);
  const int x = grey.cols - 2 * c;
  int bad = 0;
  for (int k = 0; (k + 1) * c <= grey.rows; ++k) {
    const cv::Rect centre(x + c / 4, k * c + c / 4, std::max(1, c / 2), std::max(1, c / 2));
    if ((cv::mean(grey(centre))[0] >= 128) != stripe_bit(frame_id, k)) ++bad;
  }
  return bad;
}

}  // namespace pvcap::sim
