#include "storage/writer/index_journal.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pvcap {
namespace {

constexpr std::size_t kJournalChunkRecords = 4096;

// What a row holds in memory, near enough to bound the rows waiting for the journal's disk.
std::size_t approx_bytes(const IndexRecord& record) {
  if (const auto* p = std::get_if<PressureRecord>(&record))
    return sizeof(PressureRecord) + p->payload.size() + 2 * p->counts.size();
  if (const auto* s = std::get_if<SampleRecord>(&record))
    return sizeof(SampleRecord) + s->cameras.size() * sizeof(SampleFrameRef);
  return 256;
}

bool write_all(int fd, const std::string& bytes, std::string& why) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      why = fmt::format("cannot write: {}", std::strerror(n < 0 ? errno : ENOSPC));
      return false;
    }
    done += std::size_t(n);
  }
  return true;
}

}  // namespace

std::vector<std::filesystem::path> index_journal_files(const std::filesystem::path& spill_folder) {
  namespace fs = std::filesystem;
  const std::string prefix = kIndexJournalPrefix;
  std::vector<std::pair<long, fs::path>> found;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(spill_folder, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string number = name.substr(prefix.size());
    if (number.empty() || !std::all_of(number.begin(), number.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    found.emplace_back(std::stol(number), e.path());
  }
  std::sort(found.begin(), found.end());
  std::vector<fs::path> out;
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

IndexJournal::IndexJournal(std::filesystem::path folder, std::chrono::milliseconds file_period)
    : folder_(std::move(folder)), file_period_(file_period) {
  thread_ = std::thread([this] { run(); });
}

IndexJournal::~IndexJournal() { stop(false); }

void IndexJournal::append(IndexRecord record) {
  appended_.fetch_add(1);
  const std::size_t bytes = approx_bytes(record);
  std::lock_guard lock(mu_);
  if (stopped_taking_) return;
  if (pending_bytes_ + bytes > kPendingBytes) {
    // Its disk is far behind: the journal stops rather than grow (the thread says so).
    stopped_taking_ = true;
    if (!failure_)
      failure_ = fmt::format("{}: could not keep up ({} MB of rows waited for its disk); it stopped", folder_.string(),
                             kPendingBytes >> 20);
    pending_.clear();
    pending_bytes_ = 0;
    cv_.notify_all();
    return;
  }
  pending_.push_back(std::move(record));
  pending_bytes_ += bytes;
  if (pending_.size() == 1) cv_.notify_all();
}

void IndexJournal::committed(std::uint64_t rows) {
  std::uint64_t seen = committed_.load();
  while (rows > seen && !committed_.compare_exchange_weak(seen, rows)) {
  }
}

void IndexJournal::keep_all() { keep_all_.store(true); }

std::optional<std::string> IndexJournal::failure() const {
  std::lock_guard lock(mu_);
  return failure_;
}

void IndexJournal::fail(const std::string& why) {
  std::lock_guard lock(mu_);
  stopped_taking_ = true;
  pending_.clear();
  pending_bytes_ = 0;
  if (!failure_) failure_ = why;
}

void IndexJournal::stop(bool remove_files) {
  {
    std::lock_guard lock(mu_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
    if (remove_files) {  // every row is in the index: nothing left to write
      pending_.clear();
      pending_bytes_ = 0;
    }
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (remove_files) {
    std::error_code ec;
    for (const File& f : files_) std::filesystem::remove(f.path, ec);
    files_.clear();
  }
}

bool IndexJournal::open_next_file() {
  std::error_code ec;
  std::filesystem::create_directories(folder_, ec);
  File file{folder_ / fmt::format("{}{}", kIndexJournalPrefix, next_number_++), rows_written_};
  fd_ = ::open(file.path.c_str(), O_CREAT | O_WRONLY | O_TRUNC | O_CLOEXEC, 0640);
  if (fd_ < 0) {
    fail(fmt::format("{}: cannot create: {}", file.path.string(), std::strerror(errno)));
    return false;
  }
  files_.push_back(std::move(file));
  file_opened_ = std::chrono::steady_clock::now();
  return true;
}

bool IndexJournal::write_out(std::vector<IndexRecord>& rows) {
  if (fd_ < 0 && !open_next_file()) return false;
  std::string bytes;
  for (std::size_t at = 0; at < rows.size(); at += kJournalChunkRecords) {
    const std::size_t end = std::min(rows.size(), at + kJournalChunkRecords);
    std::vector<IndexRecord> chunk(std::make_move_iterator(rows.begin() + std::ptrdiff_t(at)),
                                   std::make_move_iterator(rows.begin() + std::ptrdiff_t(end)));
    encode_record_chunk(chunk, bytes);
  }
  std::string why;
  if (!write_all(fd_, bytes, why)) {
    fail(fmt::format("{}: {}", files_.back().path.string(), why));
    return false;
  }
  rows_written_ += rows.size();
  files_.back().end_row = rows_written_;
  return true;
}

void IndexJournal::remove_committed_files() {
  if (keep_all_.load()) return;
  const std::uint64_t committed = committed_.load();
  // The file being written stays (closed ones only), so rows are never between files.
  while (files_.size() > (fd_ >= 0 ? 1u : 0u) && files_.front().end_row <= committed) {
    std::error_code ec;
    std::filesystem::remove(files_.front().path, ec);
    files_.pop_front();
  }
}

void IndexJournal::run() {
  bool told = false;
  std::unique_lock lock(mu_);
  for (;;) {
    cv_.wait_for(lock, std::chrono::milliseconds(100),
                 [&] { return stopping_ || !pending_.empty() || (failure_ && !told); });
    std::vector<IndexRecord> rows;
    rows.swap(pending_);
    pending_bytes_ = 0;
    const bool stopping = stopping_;
    const std::optional<std::string> failure = failure_;
    lock.unlock();
    if (failure && !told) {
      spdlog::warn(
          "session index: its journal of rows not yet committed stopped ({}); rows still go into the index, but "
          "those waiting for it would not survive a crash",
          *failure);
      told = true;
    }
    if (!rows.empty()) write_out(rows);
    if (fd_ >= 0 && std::chrono::steady_clock::now() - file_opened_ >= file_period_) {
      ::close(fd_);  // the next rows start the next file, so this one can go once they are committed
      fd_ = -1;
    }
    remove_committed_files();
    lock.lock();
    if (stopping && pending_.empty()) return;
  }
}

}  // namespace pvcap
