#include "storage/writer/index_overflow.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pvcap {
namespace {

constexpr std::size_t kChunkRecords = 4096;

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
  std::vector<IndexRecord> records;
  records.reserve(items.size());
  for (auto& item : items) records.push_back(to_index_record(std::move(item)));
  std::string out;
  encode_record_chunk(records, out);
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
  auto records = done == bytes ? decode_record_chunks(data) : RecordChunks{{}, 1};
  if (records.unreadable_bytes > 0) {
    std::lock_guard lock(mu_);
    if (!failure_) failure_ = fmt::format("{}: waiting rows could not be read back (the disk failed)", file_.string());
    return out;
  }
  for (auto& r : records.records) out.push_back(to_queue_item(std::move(r)));
  return out;
}

Result<RecordChunks> read_record_file(const std::filesystem::path& file) {
  std::ifstream f(file, std::ios::binary);
  if (!f) return Error{fmt::format("{}: cannot be read: {}", file.string(), std::strerror(errno))};
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) return Error{fmt::format("{}: cannot be read: {}", file.string(), std::strerror(errno))};
  return decode_record_chunks(bytes);
}

}  // namespace pvcap
