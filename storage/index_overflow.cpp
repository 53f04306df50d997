#include "storage/index_overflow.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <zlib.h>

namespace pvcap {
namespace {

constexpr char kChunkMagic[4] = {'P', 'V', 'I', 'X'};
constexpr std::size_t kChunkHeader = 12;  // magic, u32 bytes after the header, u32 CRC-32 of them
constexpr std::size_t kChunkRecords = 4096;

// The records of one chunk's bytes (header included); nullopt when they are not a whole chunk.
std::optional<std::vector<IndexRecord>> decode_chunk(const std::string& data) {
  if (data.size() < kChunkHeader || std::memcmp(data.data(), kChunkMagic, 4) != 0) return std::nullopt;
  std::uint32_t size = 0, crc = 0;
  std::memcpy(&size, data.data() + 4, 4);
  std::memcpy(&crc, data.data() + 8, 4);
  if (size != data.size() - kChunkHeader ||
      std::uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(data.data() + kChunkHeader), uInt(size))) != crc)
    return std::nullopt;
  std::vector<IndexRecord> out;
  std::size_t pos = kChunkHeader;
  while (pos < data.size()) {
    auto r = decode_record(data, pos);
    if (!r) return std::nullopt;
    out.push_back(std::move(*r));
  }
  return out;
}

IndexRecord to_index_record(IndexQueueItem&& item) {
  return std::visit(
      [](auto&& r) -> IndexRecord {
        using T = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<T, CommitBarrier>)
          return IndexRecord{};  // never called on a barrier
        else
          return IndexRecord(std::move(r));
      },
      std::move(item));
}

IndexQueueItem to_queue_item(IndexRecord&& record) {
  return std::visit([](auto&& r) { return IndexQueueItem(std::move(r)); }, std::move(record));
}

}  // namespace

IndexOverflow::IndexOverflow(std::filesystem::path file, std::size_t memory_records)
    : file_(std::move(file)), memory_records_(memory_records) {
  if (!file_.empty()) thread_ = std::thread([this] { spill_loop(); });
}

IndexOverflow::~IndexOverflow() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) {
    ::close(fd_);
    std::error_code ec;
    if (chunks_.empty()) std::filesystem::remove(file_, ec);  // everything was read back
  }
}

void IndexOverflow::add(IndexQueueItem item) {
  {
    std::lock_guard lock(mu_);
    memory_.push_back(std::move(item));
    if (memory_.size() <= memory_records_ || file_.empty()) return;
  }
  cv_.notify_all();
}

bool IndexOverflow::empty() const {
  std::lock_guard lock(mu_);
  return memory_.empty() && chunks_.empty() && in_flight_ == 0;
}

std::uint64_t IndexOverflow::spilled() const {
  std::lock_guard lock(mu_);
  return spilled_;
}

std::uint64_t IndexOverflow::lost() const {
  std::lock_guard lock(mu_);
  return lost_;
}

std::optional<std::string> IndexOverflow::failure() const {
  std::lock_guard lock(mu_);
  return failure_;
}

std::vector<IndexQueueItem> IndexOverflow::take() {
  std::unique_lock lock(mu_);
  cv_.wait(lock, [&] { return in_flight_ == 0; });
  if (!chunks_.empty()) {
    const auto [offset, bytes] = chunks_.front();
    chunks_.pop_front();
    lock.unlock();  // the spill thread appends beyond it meanwhile
    return read_chunk(offset, bytes);
  }
  std::vector<IndexQueueItem> out(std::make_move_iterator(memory_.begin()), std::make_move_iterator(memory_.end()));
  memory_.clear();
  return out;
}

void IndexOverflow::spill_loop() {
  std::unique_lock lock(mu_);
  for (;;) {
    cv_.wait(lock, [&] { return stopping_ || (memory_.size() > memory_records_ && !failure_); });
    if (stopping_) return;
    // The oldest records in memory, down to half the bound: a few large writes, not one per record.
    std::vector<IndexQueueItem> chunk;
    while (memory_.size() > memory_records_ / 2 && chunk.size() < kChunkRecords) {
      IndexQueueItem item = std::move(memory_.front());
      memory_.pop_front();
      if (auto* barrier = std::get_if<CommitBarrier>(&item)) {
        barrier->committed->set_value(false);  // not committed in time: refused, not written to disk
        continue;
      }
      chunk.push_back(std::move(item));
    }
    if (chunk.empty()) continue;
    in_flight_ = chunk.size();
    lock.unlock();
    const std::int64_t at = end_;  // only this thread moves end_
    const bool written = write_chunk(chunk);
    lock.lock();
    in_flight_ = 0;
    if (written) {
      chunks_.emplace_back(at, std::size_t(end_ - at));
      spilled_ += chunk.size();
    } else {
      lost_ += chunk.size();
    }
    cv_.notify_all();
  }
}

bool IndexOverflow::write_chunk(std::vector<IndexQueueItem>& items) {
  std::string body;
  for (auto& item : items) encode_record(to_index_record(std::move(item)), body);
  std::string out(kChunkHeader, '\0');
  std::memcpy(out.data(), kChunkMagic, 4);
  const auto size = std::uint32_t(body.size());
  const auto crc = std::uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size())));
  std::memcpy(out.data() + 4, &size, 4);
  std::memcpy(out.data() + 8, &crc, 4);
  out += body;
  auto fail = [&](const std::string& why) {
    std::lock_guard lock(mu_);
    if (!failure_) failure_ = fmt::format("{}: {}", file_.string(), why);
    return false;
  };
  if (fd_ < 0) {
    std::filesystem::create_directories(file_.parent_path());
    fd_ = ::open(file_.c_str(), O_CREAT | O_RDWR | O_TRUNC | O_CLOEXEC, 0640);
    if (fd_ < 0) return fail(fmt::format("cannot create: {}", std::strerror(errno)));
    spdlog::info("session index: its waiting rows go on disk too, to {}", file_.string());
  }
  std::size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = ::pwrite(fd_, out.data() + done, out.size() - done, end_ + std::int64_t(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return fail(fmt::format("cannot write: {}", std::strerror(n < 0 ? errno : ENOSPC)));
    done += std::size_t(n);
  }
  end_ += std::int64_t(out.size());
  return true;
}

std::vector<IndexQueueItem> IndexOverflow::read_chunk(std::int64_t offset, std::size_t bytes) {
  std::string data(bytes, '\0');
  std::size_t done = 0;
  while (done < bytes) {
    const ssize_t n = ::pread(fd_, data.data() + done, bytes - done, offset + std::int64_t(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += std::size_t(n);
  }
  std::vector<IndexQueueItem> out;
  auto records = done == bytes ? decode_chunk(data) : std::nullopt;
  if (!records) {
    std::lock_guard lock(mu_);
    if (!failure_) failure_ = fmt::format("{}: waiting rows could not be read back (the disk failed)", file_.string());
    return out;
  }
  for (auto& r : *records) out.push_back(to_queue_item(std::move(r)));
  return out;
}

Result<WaitingRows> read_index_overflow(const std::filesystem::path& file) {
  std::ifstream f(file, std::ios::binary);
  if (!f) return Error{fmt::format("{}: cannot be read: {}", file.string(), std::strerror(errno))};
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) return Error{fmt::format("{}: cannot be read: {}", file.string(), std::strerror(errno))};
  WaitingRows out;
  std::size_t pos = 0;
  while (pos + kChunkHeader <= bytes.size()) {
    std::uint32_t size = 0;
    std::memcpy(&size, bytes.data() + pos + 4, 4);
    if (size > bytes.size() - pos - kChunkHeader) break;  // cut by the crash
    auto records = decode_chunk(bytes.substr(pos, kChunkHeader + size));
    if (!records) break;
    std::move(records->begin(), records->end(), std::back_inserter(out.records));
    pos += kChunkHeader + size;
  }
  out.unreadable_bytes = bytes.size() - pos;
  return out;
}

}  // namespace pvcap
