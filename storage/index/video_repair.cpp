#include "storage/index/video_repair.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
}

#include <algorithm>
#include <cstdlib>
#include <vector>

#include <fmt/format.h>

#include "storage/index/records.h"
#include "storage/video/av_handles.h"
#include "storage/video/av_log.h"
#include "storage/video/frame_checksum.h"
#include "storage/video/video_reader.h"

namespace pvcap {

Result<std::int64_t> count_video_frames(const std::filesystem::path& path) {
  auto reader = VideoReader::open(path);
  if (!reader) return reader.error();
  std::int64_t n = 0, pts = 0;
  bool key = false;
  for (;;) {
    auto more = reader.value()->next_packet(pts, key);
    if (!more || !more.value()) break;  // a cut tail ends the count
    ++n;
  }
  return n;
}

Result<std::int64_t> count_frames_matching_index(SessionIndex& index, const std::filesystem::path& session_dir,
                                                 std::int64_t id, std::int64_t started_host_ns) {
  auto& db = index.db();
  std::string path;
  {
    auto q = db.prepare("SELECT path FROM video_files WHERE id = ?");
    q.bind_all(id);
    if (!q.step())
      throw sqlite::SqliteError(0, fmt::format("{}: no video file {} in the index", db.path().string(), id));
    path = q.column_text(0);
  }
  struct Row {
    VideoTimestamp ts;
    std::optional<std::uint32_t> checksum;
  };
  std::vector<Row> rows;
  {
    auto q = db.prepare(
        "SELECT host_ns, video_pts_ms, checksum FROM frames WHERE video_file_id = ? AND kept = 1 ORDER BY video_index");
    q.bind_all(id);
    while (q.step())
      rows.push_back({video_timestamp(q.column_null(1) ? std::nullopt : std::optional(q.column_int(1)), q.column_int(0),
                                      started_host_ns),
                      q.column_null(2) ? std::nullopt : std::optional(std::uint32_t(q.column_int(2)))});
  }
  auto reader = VideoReader::open(session_dir / path);
  if (!reader) return reader.error();
  VideoReader& video = *reader.value();
  std::int64_t n = 0, pts_ms = 0;
  bool key = false;
  cv::Mat picture;
  // A raw video is decoded when there are checksums to hold its frames to (a store before format 5
  // has none); otherwise its packets are read as they are.
  const bool decode = video.raw() && std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.checksum; });
  for (const Row& row : rows) {
    auto more = decode ? video.next_stored(picture, pts_ms, key) : video.next_packet(pts_ms, key);
    if (!more || !more.value()) break;  // a cut tail ends the count
    if (std::llabs(pts_ms - row.ts.ms) > row.ts.tolerance_ms) break;
    if (decode && row.checksum && picture_crc(picture) != *row.checksum) break;
    ++n;
  }
  return n;
}

ReconcileResult reconcile_video_file(SessionIndex& index, const std::filesystem::path& session_dir, std::int64_t id,
                                     std::string_view reason, std::string_view state) {
  auto& db = index.db();
  ReconcileResult r;
  {
    auto q = db.prepare("SELECT path FROM video_files WHERE id = ?");
    q.bind_all(id);
    if (!q.step())
      throw sqlite::SqliteError(0, fmt::format("{}: no video file {} in the index", db.path().string(), id));
    r.path = q.column_text(0);
  }
  auto counted = count_video_frames(session_dir / r.path);
  r.frames_in_file = counted ? counted.value() : 0;
  sqlite::Transaction tx(db);
  db.prepare(
        "UPDATE frames SET kept = 0, reason = ?, video_index = NULL WHERE video_file_id = ? AND kept = 1 AND "
        "video_index >= ?")
      .bind_all(reason, id, r.frames_in_file)
      .run();
  r.rows_marked_lost = db.changes();
  db.prepare("UPDATE video_files SET state = ?, frames = ? WHERE id = ?").bind_all(state, r.frames_in_file, id).run();
  tx.commit();
  return r;
}

Status remux_prefix(const std::filesystem::path& from, const std::filesystem::path& to, std::int64_t frames) {
  const std::string where = from.string();
  route_ffmpeg_log();
  const FfmpegLogQuiet quiet;  // `from` was cut by a crash: it ends early; failures are returned, named
  av::InputFormat in;
  if (avformat_open_input(&in.ptr, from.c_str(), nullptr, nullptr) < 0 ||
      avformat_find_stream_info(in.ptr, nullptr) < 0)
    return Error{fmt::format("{}: not a readable video file", where)};
  const int stream = av_find_best_stream(in.ptr, AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
  if (stream < 0) return Error{fmt::format("{}: no video stream", where)};
  av::OutputFormat out;
  if (avformat_alloc_output_context2(&out.ptr, nullptr, "matroska", to.c_str()) < 0)
    return Error{fmt::format("{}: cannot create a Matroska file", to.string())};
  // Every video stream goes across: a tiled raw video keeps one per tile (storage/video/bayer_tiles.h),
  // each with its own description (layout, Bayer pattern, which tile). Frames are counted on the first
  // tile's stream (the best one: the writer made it first); a frame's other tiles follow it in the file.
  std::vector<int> out_index(in.ptr->nb_streams, -1);
  int first = -1;
  for (unsigned i = 0; i < in.ptr->nb_streams; ++i) {
    const AVStream* is = in.ptr->streams[i];
    if (is->codecpar->codec_type != AVMEDIA_TYPE_VIDEO) continue;
    AVStream* os = avformat_new_stream(out.ptr, nullptr);
    avcodec_parameters_copy(os->codecpar, is->codecpar);
    os->time_base = is->time_base;
    av_dict_copy(&os->metadata, is->metadata, 0);
    out_index[i] = os->index;
    const AVDictionaryEntry* tile = av_dict_get(is->metadata, "PVCAP_TILE", nullptr, 0);
    if (tile ? std::atoi(tile->value) == 0 : int(i) == stream) first = int(i);
  }
  if (first < 0) first = stream;
  if (avio_open(&out.ptr->pb, to.c_str(), AVIO_FLAG_WRITE) < 0)
    return Error{fmt::format("{}: cannot create the file", to.string())};
  if (avformat_write_header(out.ptr, nullptr) < 0) return Error{fmt::format("{}: cannot write a header", to.string())};
  av::Packet pkt(av_packet_alloc());
  for (std::int64_t n = 0;;) {
    if (av_read_frame(in.ptr, pkt.ptr) < 0) break;
    const int i = pkt.ptr->stream_index;
    if (i == first && n++ == frames) break;  // the first frame past the prefix begins
    if (i >= 0 && std::size_t(i) < out_index.size() && out_index[std::size_t(i)] >= 0) {
      av_packet_rescale_ts(pkt.ptr, in.ptr->streams[i]->time_base, out.ptr->streams[out_index[std::size_t(i)]]->time_base);
      pkt.ptr->stream_index = out_index[std::size_t(i)];
      pkt.ptr->pos = -1;
      if (av_write_frame(out.ptr, pkt.ptr) < 0) return Error{fmt::format("{}: cannot write", to.string())};
    }
    av_packet_unref(pkt.ptr);
  }
  if (av_write_trailer(out.ptr) < 0) return Error{fmt::format("{}: cannot finish the file", to.string())};
  if (avio_closep(&out.ptr->pb) < 0) return Error{fmt::format("{}: cannot close the file", to.string())};
  return {};
}

}  // namespace pvcap
