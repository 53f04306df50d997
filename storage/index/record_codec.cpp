#include "storage/index/record_codec.h"

#include <cstring>
#include <iterator>
#include <type_traits>

#include <zlib.h>

namespace pvcap {
namespace {

// Each record kind's fields, in one list that both directions walk; a field added later is walked only
// in the codec versions that have it (`f.version`).
template <class F>
void fields(FrameRecord& r, F&& f) {
  f(r.device_id), f(r.connection), f(r.sequence), f(r.frame_id), f(r.device_ns), f(r.host_ns), f(r.aravis_system_ns),
      f(r.status), f(r.kept), f(r.reason), f(r.video_file_id), f(r.video_index), f(r.mapped_ns), f(r.video_pts_ms),
      f(r.checksum), f(r.chunk_frame_counter), f(r.chunk_timestamp), f(r.chunk_exposure_us), f(r.chunk_gain);
  if (f.version >= 2) f(r.chunk_line_status);
}
template <class F>
void fields(PressureRecord& r, F&& f) {
  f(r.device_id), f(r.connection), f(r.sequence), f(r.lost_before), f(r.device_ns), f(r.host_ns), f(r.host_wait_ns),
      f(r.grid_cols), f(r.grid_rows), f(r.grid_xscale), f(r.grid_yscale), f(r.payload), f(r.mapped_ns), f(r.base),
      f(r.counts), f(r.checksum);
}
template <class F>
void fields(DropRecord& r, F&& f) {
  f(r.device_id), f(r.connection), f(r.first_sequence), f(r.count), f(r.reason), f(r.host_ns);
}
template <class F>
void fields(EventRecord& r, F&& f) {
  f(r.host_ns), f(r.kind), f(r.device_id), f(r.message);
}
template <class F>
void fields(SampleFrameRef& r, F&& f) {
  f(r.device_id), f(r.connection), f(r.sequence), f(r.offset_ns);
}
template <class F>
void fields(SampleRecord& r, F&& f) {
  f(r.index), f(r.tick), f(r.tick_ns), f(r.t_ns), f(r.span_ns), f(r.cameras), f(r.pressure), f(r.pressure_before),
      f(r.pressure_after);
}
template <class F>
void fields(ClockModelRecord& r, F&& f) {
  f(r.device_id), f(r.host_ns), f(r.segment), f(r.x0_device_ns), f(r.offset_ns), f(r.skew), f(r.latency_ns),
      f(r.source), f(r.pairs), f(r.envelope_points), f(r.residual_p50_ns), f(r.residual_p99_ns);
}
template <class F>
void fields(VideoFileRecord& r, F&& f) {
  f(r.id), f(r.device_id), f(r.path), f(r.codec), f(r.pixel_format), f(r.width), f(r.height), f(r.segment), f(r.layout),
      f(r.bayer_format), f(r.bit_depth);
}
template <class F>
void fields(VideoFileClosed& r, F&& f) {
  f(r.id), f(r.frames);
}
template <class F>
void fields(ProtocolEventRecord& r, F&& f) {
  f(r.host_ns), f(r.kind), f(r.step), f(r.action), f(r.hand), f(r.force), f(r.repetition), f(r.detail);
}
template <class F>
void fields(OperatorNoteRecord& r, F&& f) {
  f(r.host_ns), f(r.text);
}

struct FieldProbe {
  int version = 0;
  template <class T>
  void operator()(T&) {}
};
template <class T>
concept HasFields = requires(T& t, FieldProbe& probe) { fields(t, probe); };

struct Writer {
  std::string& out;
  int version;
  template <class T>
  void operator()(const T& v) {
    if constexpr (std::is_arithmetic_v<T>) {
      out.append(reinterpret_cast<const char*>(&v), sizeof v);
    } else if constexpr (std::is_same_v<T, std::string>) {
      (*this)(std::uint64_t(v.size()));
      out.append(v);
    } else if constexpr (HasFields<T>) {
      fields(const_cast<T&>(v), *this);
    } else if constexpr (requires { v.has_value(); }) {
      (*this)(std::uint8_t(v.has_value()));
      if (v) (*this)(*v);
    } else {  // a vector
      (*this)(std::uint64_t(v.size()));
      for (const auto& x : v) (*this)(x);
    }
  }
};

struct Reader {
  const std::string& in;
  std::size_t& pos;
  int version;
  bool ok = true;
  template <class T>
  void operator()(T& v) {
    if (!ok) return;
    if constexpr (std::is_arithmetic_v<T>) {
      if (in.size() - pos < sizeof v) return void(ok = false);
      std::memcpy(&v, in.data() + pos, sizeof v);
      pos += sizeof v;
    } else if constexpr (std::is_same_v<T, std::string>) {
      std::uint64_t n = 0;
      (*this)(n);
      if (!ok || in.size() - pos < n) return void(ok = false);
      v.assign(in, pos, n);
      pos += n;
    } else if constexpr (HasFields<T>) {
      fields(v, *this);
    } else if constexpr (requires { v.has_value(); }) {
      std::uint8_t has = 0;
      (*this)(has);
      if (!ok || has > 1) return void(ok = false);
      if (has)
        (*this)(v.emplace());
      else
        v.reset();
    } else {
      std::uint64_t n = 0;
      (*this)(n);
      if (!ok || n > in.size() - pos) return void(ok = false);  // each element takes a byte at least
      v.resize(n);
      for (auto& x : v) (*this)(x);
    }
  }
};

template <std::size_t I = 0>
std::optional<IndexRecord> decode_kind(std::size_t kind, Reader& r) {
  if constexpr (I == std::variant_size_v<IndexRecord>) {
    return std::nullopt;
  } else {
    if (kind != I) return decode_kind<I + 1>(kind, r);
    std::variant_alternative_t<I, IndexRecord> v;
    fields(v, r);
    if (!r.ok) return std::nullopt;
    return IndexRecord(std::in_place_index<I>, std::move(v));
  }
}

}  // namespace

void encode_record(const IndexRecord& record, std::string& out, int version) {
  Writer w{out, version};
  w(std::uint8_t(record.index()));
  std::visit([&](const auto& r) { fields(const_cast<std::decay_t<decltype(r)>&>(r), w); }, record);
}

std::optional<IndexRecord> decode_record(const std::string& bytes, std::size_t& pos, int version) {
  std::size_t at = pos;
  Reader r{bytes, at, version};
  std::uint8_t kind = 0;
  r(kind);
  if (!r.ok) return std::nullopt;
  auto out = decode_kind(kind, r);
  if (out) pos = at;
  return out;
}

namespace {
// A chunk's magic says its records' codec version: "PVIX" 1, "PVI2" 2.
constexpr char kChunkMagics[2][4] = {{'P', 'V', 'I', 'X'}, {'P', 'V', 'I', '2'}};
static_assert(std::size(kChunkMagics) == kRecordCodecVersion);

int chunk_version(const char* magic) {
  for (int v = 1; v <= kRecordCodecVersion; ++v)
    if (std::memcmp(magic, kChunkMagics[v - 1], 4) == 0) return v;
  return 0;
}

std::uint32_t crc_of(const char* data, std::size_t size) {
  return std::uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(data), uInt(size)));
}
}  // namespace

void encode_record_chunk(const std::vector<IndexRecord>& records, std::string& out, int version) {
  const std::size_t at = out.size();
  out.append(kRecordChunkHeader, '\0');
  for (const auto& r : records) encode_record(r, out, version);
  const auto size = std::uint32_t(out.size() - at - kRecordChunkHeader);
  const auto crc = crc_of(out.data() + at + kRecordChunkHeader, size);
  std::memcpy(out.data() + at, kChunkMagics[version - 1], 4);
  std::memcpy(out.data() + at + 4, &size, 4);
  std::memcpy(out.data() + at + 8, &crc, 4);
}

RecordChunks decode_record_chunks(const std::string& bytes) {
  RecordChunks out;
  std::size_t pos = 0;
  while (pos + kRecordChunkHeader <= bytes.size()) {
    std::uint32_t size = 0, crc = 0;
    const int version = chunk_version(bytes.data() + pos);
    if (version == 0) break;
    std::memcpy(&size, bytes.data() + pos + 4, 4);
    std::memcpy(&crc, bytes.data() + pos + 8, 4);
    if (size > bytes.size() - pos - kRecordChunkHeader) break;  // cut by the crash
    if (crc_of(bytes.data() + pos + kRecordChunkHeader, size) != crc) break;
    const std::size_t end = pos + kRecordChunkHeader + size;
    // The chunk's records must end exactly at its end.
    const std::string body = bytes.substr(pos + kRecordChunkHeader, size);
    std::vector<IndexRecord> chunk;
    std::size_t at = 0;
    while (at < body.size()) {
      auto r = decode_record(body, at, version);
      if (!r) break;
      chunk.push_back(std::move(*r));
    }
    if (at != body.size()) break;
    std::move(chunk.begin(), chunk.end(), std::back_inserter(out.records));
    pos = end;
  }
  out.unreadable_bytes = bytes.size() - pos;
  return out;
}

}  // namespace pvcap
