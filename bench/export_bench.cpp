// Export speed: `pvcap export`'s work (decode, JPEG, force pickles, checksums, metadata) on a
// recorded protocol session, beside the time the JPEG encoder alone needs for the same frames
// (OpenCV's imencode at the same quality, the images decoded beforehand and not timed).
//
//   build/bench/export_bench SESSION [jpeg_quality]
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include <opencv2/imgcodecs.hpp>

#include "export/dataset_export.h"
#include "storage/index/session_reader.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: export_bench SESSION [jpeg_quality]\n");
    return 2;
  }
  const fs::path session = argv[1];
  const int quality = argc > 2 ? std::atoi(argv[2]) : 95;
  const fs::path out = fs::temp_directory_path() / ("pvcap-export-bench-" + std::to_string(getpid()));
  pvcap::exporting::ExportOptions o;
  o.out = out;
  o.jpeg_quality = quality;
  std::atomic<bool> stop{false};
  const auto t0 = Clock::now();
  auto r = pvcap::exporting::export_session(session, o, stop);
  const double export_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!r) {
    std::fprintf(stderr, "%s\n", r.error().message.c_str());
    return 1;
  }
  std::size_t frames = 0;
  for (const auto& s : r.value().sequences) frames += s.frames;
  const std::size_t cameras = r.value().cameras.size();

  // The reference: the same frames through the JPEG encoder alone.
  auto reader = pvcap::SessionReader::open(session);
  if (!reader) return 1;
  double encode_s = 0;
  std::size_t encoded = 0;
  std::size_t bytes = 0;
  // Samples the export kept are listed in each sequence's metadata (pvcap.samples).
  for (const auto& s : r.value().sequences) {
    std::ifstream in(out / s.folder / "metadata.json");
    const auto meta = nlohmann::json::parse(in);
    for (const auto& i : meta["pvcap"]["samples"]) {
      for (std::size_t c = 0; c < cameras; ++c) {
        auto image = reader.value()->image(i.get<std::size_t>(), c);
        if (!image) return 1;
        std::vector<std::uint8_t> jpeg;
        const auto e0 = Clock::now();
        cv::imencode(".jpg", image.value(), jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
        encode_s += std::chrono::duration<double>(Clock::now() - e0).count();
        bytes += jpeg.size();
        ++encoded;
      }
    }
  }
  std::printf("session: %s\n", session.c_str());
  std::printf("exported: %zu sequences, %zu samples x %zu cameras = %zu JPEGs (quality %d), %.1f MB of JPEG\n",
              r.value().sequences.size(), frames, cameras, frames * cameras, quality, double(bytes) / 1e6);
  std::printf("export: %.1f s, %.1f samples/s (%.1f camera frames/s)\n", export_s, double(frames) / export_s,
              double(frames * cameras) / export_s);
  std::printf("JPEG encoder alone, same frames: %.1f s (%.1f frames/s)\n", encode_s, double(encoded) / encode_s);
  std::printf("ratio export / encoder alone: %.2f\n", export_s / encode_s);
  fs::remove_all(out);
  return 0;
}
