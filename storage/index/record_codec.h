#pragma once
// Index records as bytes, for the rows that wait on disk while the index is behind
// (storage/writer/index_overflow.h) and for the journal of rows not yet committed (storage/writer/index_journal.h).
// Each kind lists its fields once (record_codec.cpp); the round trip is tested field by field. Read
// back on the machine that wrote them (its byte order).
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "storage/index/records.h"

namespace pvcap {

using IndexRecord = std::variant<FrameRecord, PressureRecord, DropRecord, EventRecord, SampleRecord, ClockModelRecord,
                                 VideoFileRecord, VideoFileClosed, ProtocolEventRecord, OperatorNoteRecord>;

// The records' field lists as pvcap wrote them: 1 until store version 7 (frames without their line
// levels), 2 since. A journal an older pvcap left behind is read in its own version (the chunk's magic
// says which); only tests write an older one.
inline constexpr int kRecordCodecVersion = 2;

// Appends `record` to `out`.
void encode_record(const IndexRecord& record, std::string& out, int version = kRecordCodecVersion);
// Decodes the record at `pos` of `bytes` and moves `pos` past it; nullopt when the bytes are not a
// whole record (damage, or a cut).
std::optional<IndexRecord> decode_record(const std::string& bytes, std::size_t& pos,
                                         int version = kRecordCodecVersion);

// Files of records are written in chunks: a magic ("PVIX" for codec version 1, "PVI2" for 2), the u32
// length of what follows the header and its CRC-32, then the records. A crash cuts at most the last
// chunk, and a cut one is seen as such.
inline constexpr std::size_t kRecordChunkHeader = 12;
// Appends one chunk holding `records` to `out`.
void encode_record_chunk(const std::vector<IndexRecord>& records, std::string& out,
                         int version = kRecordCodecVersion);

// The records of a file's whole chunks, in order, and how many bytes at its end are not a whole
// chunk (a write the crash cut, or damage: nothing after it is read).
struct RecordChunks {
  std::vector<IndexRecord> records;
  std::uint64_t unreadable_bytes = 0;
};
RecordChunks decode_record_chunks(const std::string& bytes);

}  // namespace pvcap
