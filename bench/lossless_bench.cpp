// Lossless codecs for the raw store, compared on the store bench's 1080p mosaics, noisy and clean
// (issue: performance, lossless bytes). Every candidate the installed FFmpeg offers encodes the
// mosaic's four Bayer planes stacked (960x2160 grey, exactly as the store gives them to its
// encoder), frame by frame with 2 threads; then each is decoded and compared with its source.
// Printed per candidate: MB per frame, frames/s encoding and decoding, bit-exact or not, and
// whether every frame decodes alone (intra-only: the store's random access). For scale: the raw
// store must keep 4 cameras x 15 Hz = 60 frames/s beside the capture on 2 cores; its default
// (ffvhuff) is the first line; above the noisy table, the least any lossless coder can average on
// those frames (the noise's entropy, bench::noise_bound_bytes). Figures in docs/performance-log.md.
// Below each table, the stored layouts (storage/video/bayer_tiles.h) through the store's own writer
// and reader: size, encode and decode CPU per frame, whole and for a paper crop.
// Usage: lossless_bench [FRAMES=20] [NOISE_DN=2] [CANDIDATE_SUBSTRING | layouts]
extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/opt.h>
#include <libavutil/pixdesc.h>
}

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "bench/bench_mosaics.h"
#include "core/time.h"
#include "storage/video/av_handles.h"
#include "storage/video/bayer_planes.h"
#include "storage/video/video_reader.h"
#include "storage/video/video_writer.h"

using namespace pvcap;
using Clock = std::chrono::steady_clock;

namespace {

struct Candidate {
  std::string label, codec;
  std::vector<std::pair<std::string, std::string>> options;
  int gop = 1;  // 1: every frame a key frame
};

std::vector<Candidate> candidates() {
  // (PNG is left out: 16-21 frames/s to encode here, far from the 60 the store needs.)
  std::vector<Candidate> c = {
      {"ffvhuff pred=left (the store's default)", "ffvhuff", {{"pred", "left"}}},
      {"ffvhuff pred=plane", "ffvhuff", {{"pred", "plane"}}},
      {"ffvhuff pred=median", "ffvhuff", {{"pred", "median"}}},
      {"ffvhuff pred=median context=1", "ffvhuff", {{"pred", "median"}, {"context", "1"}}},
      {"ffv1 coder=golomb slices=4", "ffv1", {{"level", "3"}, {"coder", "0"}, {"slices", "4"}, {"slicecrc", "1"}}},
      {"ffv1 coder=range slices=4", "ffv1", {{"level", "3"}, {"coder", "1"}, {"slices", "4"}, {"slicecrc", "1"}}},
      {"ffv1 coder=range context=1 slices=16",
       "ffv1",
       {{"level", "3"}, {"coder", "1"}, {"context", "1"}, {"slices", "16"}, {"slicecrc", "1"}}},
      {"magicyuv pred=left", "magicyuv", {{"pred", "left"}}},
      {"magicyuv pred=gradient", "magicyuv", {{"pred", "gradient"}}},
      {"magicyuv pred=median", "magicyuv", {{"pred", "median"}}},
      {"jpegls", "jpegls", {}},
      {"libjxl effort=1 (lossless)", "libjxl", {{"distance", "0"}, {"effort", "1"}}},
      {"libjxl effort=2 (lossless)", "libjxl", {{"distance", "0"}, {"effort", "2"}}},
      {"libjxl effort=3 (lossless)", "libjxl", {{"distance", "0"}, {"effort", "3"}}},
      {"libopenjpeg (5/3 wavelet, lossless)", "libopenjpeg", {}},
  };
  for (const char* preset : {"ultrafast", "superfast", "veryfast", "medium"})
    c.push_back({std::string("libx264 qp=0 ") + preset + " intra", "libx264", {{"preset", preset}, {"qp", "0"}}});
  c.push_back({"libx264 qp=0 ultrafast gop=15", "libx264", {{"preset", "ultrafast"}, {"qp", "0"}}, 15});
  c.push_back({"libx264 qp=0 veryfast gop=15", "libx264", {{"preset", "veryfast"}, {"qp", "0"}}, 15});
  return c;
}

struct Outcome {
  bool ok = false;
  std::string why;
  double mb_per_frame = 0, encode_fps = 0, decode_fps = 0;
  bool exact = false, intra = true;
};

Outcome run(const Candidate& cand, const std::vector<cv::Mat>& planes) {
  Outcome o;
  const AVCodec* enc_codec = avcodec_find_encoder_by_name(cand.codec.c_str());
  if (!enc_codec) {
    o.why = "not in this FFmpeg";
    return o;
  }
  av::CodecContext enc(avcodec_alloc_context3(enc_codec));
  enc.ptr->width = planes[0].cols;
  enc.ptr->height = planes[0].rows;
  enc.ptr->pix_fmt = AV_PIX_FMT_GRAY8;
  enc.ptr->time_base = {1, 15};
  enc.ptr->framerate = {15, 1};
  enc.ptr->gop_size = cand.gop;
  enc.ptr->max_b_frames = 0;
  enc.ptr->thread_count = 2;
  AVDictionary* opts = nullptr;
  for (const auto& [k, v] : cand.options) av_dict_set(&opts, k.c_str(), v.c_str(), 0);
  if (cand.codec == "libx264") av_dict_set(&opts, "x264-params", "bframes=0:slices=4", 0);
  const int rc = avcodec_open2(enc.ptr, enc_codec, &opts);
  av_dict_free(&opts);
  if (rc < 0) {
    o.why = "cannot open: " + av::error(rc);
    return o;
  }
  av::Frame frame(av_frame_alloc());
  frame.ptr->format = AV_PIX_FMT_GRAY8;
  frame.ptr->width = planes[0].cols;
  frame.ptr->height = planes[0].rows;
  av_frame_get_buffer(frame.ptr, 0);
  av::Packet pkt(av_packet_alloc());
  std::vector<std::vector<std::uint8_t>> packets;
  std::size_t bytes = 0;
  auto drain = [&] {
    while (avcodec_receive_packet(enc.ptr, pkt.ptr) == 0) {
      o.intra = o.intra && (pkt.ptr->flags & AV_PKT_FLAG_KEY);
      packets.emplace_back(pkt.ptr->data, pkt.ptr->data + pkt.ptr->size);
      bytes += std::size_t(pkt.ptr->size);
      av_packet_unref(pkt.ptr);
    }
  };
  const auto t0 = Clock::now();
  for (std::size_t i = 0; i < planes.size(); ++i) {
    av_frame_make_writable(frame.ptr);
    for (int y = 0; y < planes[i].rows; ++y)
      std::memcpy(frame.ptr->data[0] + std::ptrdiff_t(y) * frame.ptr->linesize[0], planes[i].ptr(y),
                  std::size_t(planes[i].cols));
    frame.ptr->pts = std::int64_t(i);
    if (avcodec_send_frame(enc.ptr, frame.ptr) < 0) {
      o.why = "the encoder refused a frame";
      return o;
    }
    drain();
  }
  avcodec_send_frame(enc.ptr, nullptr);
  drain();
  o.encode_fps = double(planes.size()) / std::chrono::duration<double>(Clock::now() - t0).count();
  o.mb_per_frame = double(bytes) / double(planes.size()) / 1e6;

  const AVCodec* dec_codec = avcodec_find_decoder(enc_codec->id);
  av::CodecContext dec(avcodec_alloc_context3(dec_codec));
  AVCodecParameters* par = avcodec_parameters_alloc();
  avcodec_parameters_from_context(par, enc.ptr);
  avcodec_parameters_to_context(dec.ptr, par);
  avcodec_parameters_free(&par);
  dec.ptr->thread_count = 2;
  if (avcodec_open2(dec.ptr, dec_codec, nullptr) < 0) {
    o.why = "no decoder";
    return o;
  }
  av::Frame out(av_frame_alloc());
  std::size_t decoded = 0, equal = 0;
  auto receive = [&] {
    while (avcodec_receive_frame(dec.ptr, out.ptr) == 0) {
      // A 4:0:0 H.264 stream decodes as 4:2:0 with neutral chroma: its luma plane is the picture.
      bool same =
          (out.ptr->format == AV_PIX_FMT_GRAY8 || out.ptr->format == AV_PIX_FMT_YUV420P) && decoded < planes.size();
      for (int y = 0; same && y < planes[decoded].rows; ++y)
        same = std::memcmp(out.ptr->data[0] + std::ptrdiff_t(y) * out.ptr->linesize[0], planes[decoded].ptr(y),
                           std::size_t(planes[decoded].cols)) == 0;
      equal += same;
      if (!same && o.why.empty())
        o.why = std::string("decodes as ") + (av_get_pix_fmt_name(AVPixelFormat(out.ptr->format)) ?: "?");
      ++decoded;
      av_frame_unref(out.ptr);
    }
  };
  const auto t1 = Clock::now();
  for (auto& p : packets) {
    av::Packet in(av_packet_alloc());
    av_new_packet(in.ptr, int(p.size()));
    std::memcpy(in.ptr->data, p.data(), p.size());
    avcodec_send_packet(dec.ptr, in.ptr);
    receive();
  }
  avcodec_send_packet(dec.ptr, nullptr);
  receive();
  o.decode_fps = double(decoded) / std::chrono::duration<double>(Clock::now() - t1).count();
  o.exact = decoded == planes.size() && equal == decoded;
  o.ok = true;
  return o;
}

// One stored layout through the store's own writer and reader (storage/video): the mosaics written
// to a file with `codec` cut into `cols` x `rows` tiles, then read back whole and as paper-sized
// crops (480x384 with the demosaicing margin, at random places), all on one thread: CPU per frame.
void layout_row(const std::string& label, const std::string& codec, int gop, int cols, int rows,
                const std::vector<cv::Mat>& mosaics, const std::string& options = "", bool fitted = false) {
  const auto file =
      std::filesystem::temp_directory_path() / ("pvcap-lossless-bench-" + std::to_string(::getpid()) + ".mkv");
  VideoSettings s;
  s.bayer_format = "BayerRG8";
  s.raw_codec = codec;
  s.width = mosaics[0].cols;
  s.height = mosaics[0].rows;
  s.tile_cols = cols;
  s.tile_rows = rows;
  s.gop_frames = gop;
  s.raw_codec_options = options;
  for (std::size_t i = 0; fitted && i < std::min<std::size_t>(16, mosaics.size()); ++i) {  // as compact fits them
    cv::Mat planes;
    pack_bayer_planes(mosaics[i], planes, kCellOrder);
    add_left_residual_counts(planes, s.residual_counts);
  }
  auto w = VideoWriter::open(file, s);
  if (!w) {
    std::printf("%-34s %s\n", label.c_str(), w.error().message.c_str());
    return;
  }
  const std::string grid = w.value()->tile_grid().tag();
  double t0 = process_cpu_seconds();
  for (std::size_t i = 0; i < mosaics.size(); ++i)
    if (!w.value()->write(mosaics[i], std::int64_t(i + 1) * 66'667)) return;
  if (!w.value()->close().ok()) return;
  const double encode_ms = (process_cpu_seconds() - t0) * 1e3 / double(mosaics.size());
  const double mb = double(std::filesystem::file_size(file)) / 1e6 / double(mosaics.size());
  auto r = VideoReader::open(file);
  if (!r) return;
  bool exact = true;
  cv::Mat m;
  t0 = process_cpu_seconds();
  for (std::size_t i = 0; i < mosaics.size(); ++i) {
    const std::int64_t pts = (std::int64_t(i + 1) * 66'667 + 500) / 1000;
    exact = exact && r.value()->read_raw_at(pts, m).value() && cv::norm(m, mosaics[i], cv::NORM_INF) == 0;
  }
  const double whole_ms = (process_cpu_seconds() - t0) * 1e3 / double(mosaics.size());
  // Shuffled, as training reads: a 480x384 box and the simulated rig's paper crop (the pad's box
  // with its margin, ~900x720 at 1080p), each with the demosaicing margin.
  const auto crop_ms = [&](cv::Size size) {
    cv::RNG rng(5);
    const int crops = 3 * int(mosaics.size());
    const double start = process_cpu_seconds();
    for (int k = 0; k < crops; ++k) {
      const std::size_t i = std::size_t(rng.uniform(0, int(mosaics.size())));
      const cv::Size whole = mosaics[i].size();
      const cv::Rect box(rng.uniform(0, (whole.width - size.width) / 2) * 2,
                         rng.uniform(0, (whole.height - size.height) / 2) * 2, size.width, size.height);
      const std::int64_t pts = (std::int64_t(i + 1) * 66'667 + 500) / 1000;
      exact = exact && r.value()->read_raw_region_at(pts, box, m).value() &&
              cv::norm(m, mosaics[i](box), cv::NORM_INF) == 0;
    }
    return (process_cpu_seconds() - start) * 1e3 / crops;
  };
  const double small = crop_ms({484, 388}), paper = crop_ms({904, 724});
  std::printf("%-40s %5s %8.3f %10.2f %10.2f %9.2f %10.2f %9s\n", label.c_str(), grid.c_str(), mb, encode_ms, whole_ms,
              small, paper, exact ? "bit-exact" : "NO");
  std::fflush(stdout);
  std::filesystem::remove(file);
}

void layouts(const std::vector<cv::Mat>& mosaics) {
  std::printf(
      "\nstored layouts through the store's writer and reader, one thread, CPU ms per 1080p frame; crops of 480x384 "
      "and ~900x720 (the simulated rig's paper crop), with the demosaicing margin, shuffled\n");
  std::printf("%-40s %5s %8s %10s %10s %9s %10s %9s\n", "layout", "tiles", "MB/frame", "encode ms", "whole ms",
              "480x384", "900x720", "exact");
  layout_row("ffvhuff, one picture (until now)", "ffvhuff", 1, 1, 1, mosaics);
  for (const auto& [c, r] : std::vector<std::pair<int, int>>{{4, 4}, {8, 6}, {16, 12}})
    layout_row("ffvhuff, tiles (the store's)", "ffvhuff", 1, c, r, mosaics);
  layout_row("ffvhuff left, fitted tables (compact)", "ffvhuff", 1, 8, 6, mosaics, "pred=left", true);
  layout_row("ffvhuff left context=1, tiles", "ffvhuff", 1, 8, 6, mosaics, "pred=left:context=1");
  layout_row("ffvhuff median context=1, tiles", "ffvhuff", 1, 8, 6, mosaics, "pred=median:context=1");
  layout_row("magicyuv, tiles", "magicyuv", 1, 8, 6, mosaics);
  layout_row("ffv1 intra (compact), tiles", "ffv1", 1, 8, 6, mosaics);
  layout_row("libx264 qp 0 intra (compact), tiles", "libx264", 1, 8, 6, mosaics);
  layout_row("libx264 qp 0 gop 15 (compact until now)", "libx264", 15, 1, 1, mosaics);
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 20;
  const double noise = argc > 2 ? std::atof(argv[2]) : bench::kSensorNoiseDn;
  const std::string only = argc > 3 ? argv[3] : "";
  av_log_set_level(AV_LOG_ERROR);
  if (only == "layouts") {  // the stored layouts alone
    layouts(bench::make_mosaics(0, n, noise));
    return 0;
  }
  for (const double dn : {noise, 0.0}) {
    std::vector<cv::Mat> planes;
    for (const cv::Mat& m : bench::make_mosaics(0, n, dn)) {
      cv::Mat p;
      pack_bayer_planes(m, p);
      planes.push_back(p);
    }
    std::printf(
        "\n%s 1080p mosaics (%d frames, %.0f DN noise), four planes stacked %dx%d grey, 2 threads; raw: %.2f "
        "MB per frame\n",
        dn > 0 ? "noisy" : "clean", n, dn, planes[0].cols, planes[0].rows, double(planes[0].total()) / 1e6);
    if (dn > 0) {
      double bound = 0;
      for (const cv::Mat& clean : bench::make_mosaics(0, n, 0)) bound += bench::noise_bound_bytes(clean, dn);
      std::printf(
          "the noise's own entropy given the clean mosaics: %.3f MB per frame (no lossless coder averages less)\n",
          bound / n / 1e6);
    }
    std::printf("%-42s %9s %10s %10s %9s %6s\n", "candidate", "MB/frame", "encode f/s", "decode f/s", "exact", "intra");
    for (const Candidate& c : candidates()) {
      if (!only.empty() && c.label.find(only) == std::string::npos) continue;
      const Outcome o = run(c, planes);
      if (!o.ok) {
        std::printf("%-42s %s\n", c.label.c_str(), o.why.c_str());
        continue;
      }
      std::printf("%-42s %9.3f %10.1f %10.1f %9s %6s %s\n", c.label.c_str(), o.mb_per_frame, o.encode_fps, o.decode_fps,
                  o.exact ? "bit-exact" : "NO", o.intra ? "yes" : "no", o.exact ? "" : o.why.c_str());
      std::fflush(stdout);
    }
    if (only.empty()) layouts(bench::make_mosaics(0, n, dn));
  }
  return 0;
}
