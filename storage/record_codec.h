#pragma once
// Index records as bytes, for the rows that wait on disk while the index is behind
// (storage/index_overflow.h). Each kind lists its fields once (record_codec.cpp); the round trip is
// tested field by field. Read back by the process that wrote them (the machine's byte order).
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "storage/records.h"

namespace pvcap {

using IndexRecord = std::variant<FrameRecord, PressureRecord, DropRecord, EventRecord, SampleRecord, ClockModelRecord,
                                 VideoFileRecord, VideoFileClosed, ProtocolEventRecord, OperatorNoteRecord>;

// Appends `record` to `out`.
void encode_record(const IndexRecord& record, std::string& out);
// Decodes the record at `pos` of `bytes` and moves `pos` past it; nullopt when the bytes are not a
// whole record (damage, or a cut).
std::optional<IndexRecord> decode_record(const std::string& bytes, std::size_t& pos);

}  // namespace pvcap
