#include "storage/writer/index_writer.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/time.h"

namespace pvcap {

IndexWriter::IndexWriter(SessionIndex& index, std::size_t capacity, std::chrono::milliseconds batch_period,
                         std::optional<Stall> stall, std::filesystem::path overflow_file,
                         std::size_t overflow_memory_records, std::filesystem::path journal_folder)
    : index_(index),
      queue_(capacity),
      queue_capacity_(capacity),
      batch_period_(batch_period),
      stall_(stall),
      overflow_(std::move(overflow_file), overflow_memory_records) {
  if (!journal_folder.empty()) journal_ = std::make_unique<IndexJournal>(std::move(journal_folder));
}

IndexWriter::~IndexWriter() { stop(); }

void IndexWriter::start() {
  thread_ = std::thread([this] { run(); });
}

bool IndexWriter::push(Record record) {
  auto lose = [&] {
    lost_by_kind_[record.index()].fetch_add(1, std::memory_order_relaxed);
    lost_.fetch_add(1, std::memory_order_relaxed);
    return false;
  };
  if (failed_.load(std::memory_order_relaxed) && !disk_full_.load(std::memory_order_relaxed)) return lose();
  // The journal's copy, made before the lock (barriers are not records).
  std::optional<IndexRecord> copy;
  if (journal_)
    std::visit(
        [&](const auto& r) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(r)>, CommitBarrier>) copy.emplace(r);
        },
        record);
  {
    // A short lock, never held across I/O: it orders the queue against the overflow, and the journal
    // against both.
    std::lock_guard lock(push_mu_);
    if (!overflowing_.load(std::memory_order_relaxed)) {
      if (queue_.try_push(record)) {
        if (copy) journal_->append(std::move(*copy));
        return true;
      }
      if (queue_.closed()) return lose();  // stopped
      behind_since_ns_.store(host_now().ns, std::memory_order_relaxed);
      overflowing_.store(true);
    }
    overflow_.add(std::move(record));
    if (copy) journal_->append(std::move(*copy));
  }
  waited_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

bool IndexWriter::take_overflow(std::vector<Record>& items) {
  if (!overflowing_.load()) return false;
  {
    std::lock_guard lock(push_mu_);  // no record is added while the overflow is found empty
    if (overflow_.empty()) {
      overflowing_.store(false);
      return false;
    }
  }
  items = overflow_.take();  // may wait for a chunk landing in the file: producers do not
  return true;
}

bool IndexWriter::push_committed(Record record, std::chrono::milliseconds timeout) {
  auto promise = std::make_shared<std::promise<bool>>();
  auto committed = promise->get_future();
  if (!push(std::move(record))) return false;
  if (!push(CommitBarrier{std::move(promise)})) return false;
  if (committed.wait_for(timeout) != std::future_status::ready) return false;
  try {
    return committed.get();
  } catch (const std::future_error&) {  // the writer stopped before reaching it
    return false;
  }
}

void IndexWriter::stop() {
  queue_.close();
  if (thread_.joinable()) thread_.join();
  if (!held_.empty()) {
    try {  // the batch that met the full disk, once more (its space was freed meanwhile)
      write_records(held_);
      spdlog::info("session index: the {} records held since the disk filled are written", held_.size());
      written_.fetch_add(held_.size());
    } catch (const sqlite::SqliteError& e) {
      lost_.fetch_add(held_.size());
      spdlog::error("session index: {} records are lost: {}", held_.size(), e.what());
    }
    held_.clear();
  }
  // The index holds every record pushed, unless some were lost: then the journal stays for recover.
  if (journal_) journal_->stop(/*remove_files=*/records_lost() == 0);
}

std::optional<std::string> IndexWriter::failure() const {
  std::lock_guard lock(failure_mu_);
  return failure_;
}

void IndexWriter::write_records(const std::vector<Record>& batch) {
  sqlite::Transaction tx(index_.db());
  for (const Record& r : batch)
    std::visit(
        [&](const auto& rec) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(rec)>, CommitBarrier>) index_.add(rec);
        },
        r);
  tx.commit();
}

void IndexWriter::write_batch(std::vector<Record>& batch) {
  if (batch.empty()) return;
  if (failed_.load()) {
    // After a full disk, records are held (bounded by the queue's size) for stop(); after any
    // other failure nothing more is written and what arrives is counted lost.
    const bool hold = disk_full_.load() && held_.size() + batch.size() <= queue_capacity_;
    if (hold)
      std::move(batch.begin(), batch.end(), std::back_inserter(held_));
    else
      lost_.fetch_add(batch.size());
    batch.clear();
    own_in_batch_ = 0;
    return;
  }
  try {
    write_records(batch);
    written_.fetch_add(batch.size());
    pushed_committed_ += batch.size() - own_in_batch_;
    if (journal_) journal_->committed(pushed_committed_);
  } catch (const sqlite::SqliteError& e) {
    if (journal_) journal_->keep_all();  // its rows are the way back for recover
    std::lock_guard lock(failure_mu_);
    failure_ = e.disk_full() ? fmt::format("the disk is full or failing: {}", e.what()) : std::string(e.what());
    if (e.disk_full())
      held_ = std::move(batch), disk_full_.store(true);
    else
      lost_.fetch_add(batch.size());
    failed_.store(true);
    spdlog::error("session index: {}", *failure_);
  }
  batch.clear();
  own_in_batch_ = 0;
}

void IndexWriter::add_own(std::vector<Record>& batch, EventRecord event) {
  batch.push_back(std::move(event));
  ++own_in_batch_;
}

std::string IndexWriter::lost_records_by_kind() const {
  static constexpr const char* kKinds[] = {"frames",          "pressure frames", "drop ranges",    "events",
                                           "samples",         "clock models",    "video files",    "video file closes",
                                           "protocol events", "operator notes",  "commit barriers"};
  static_assert(std::size(kKinds) == std::variant_size_v<Record>);
  std::string out;
  for (std::size_t i = 0; i < lost_by_kind_.size(); ++i)
    if (const auto n = lost_by_kind_[i].load(); n > 0)
      out += fmt::format("{}{} {}", out.empty() ? "" : ", ", kKinds[i], n);
  return out;
}

void IndexWriter::run() {
  // An index thread that falls behind, on purpose (core/fault_injection.h): tests meet a full queue.
  std::optional<Stall> stall = stall_;
  const auto stall_at = std::chrono::steady_clock::now() + std::chrono::duration<double>(stall ? stall->after_s : 0.0);
  std::vector<Record> batch, items;
  auto batch_started = std::chrono::steady_clock::now();
  std::uint64_t lost_reported = 0;
  bool journal_reported = false;
  for (;;) {
    if (stall && std::chrono::steady_clock::now() >= stall_at) {
      std::this_thread::sleep_for(std::chrono::duration<double>(stall->seconds));
      stall.reset();
    }
    const bool behind = overflowing_.load();
    items.clear();
    // Behind: the queue's records first (they are older), then the overflow's, without waiting.
    bool done = false;  // stopped, and nothing waits: after this round's events
    if (auto r = queue_.pop_for(std::chrono::milliseconds(behind ? 0 : 50)))
      items.push_back(std::move(*r));
    else if (!take_overflow(items) && queue_.closed_and_empty())
      done = true;
    for (Record& item : items) {
      if (auto* barrier = std::get_if<CommitBarrier>(&item)) {
        write_batch(batch);
        barrier->committed->set_value(!failed_.load());
        continue;
      }
      if (batch.empty()) batch_started = std::chrono::steady_clock::now();
      batch.push_back(std::move(item));
    }
    if (behind && !overflowing_.load()) {  // caught up: what waited, and where
      const std::uint64_t waited = waited_.load(), spilled = overflow_.spilled();
      // Waiting records are lost only when the overflow's file failed (an index_overflow event says so).
      const std::string outcome = overflow_.lost() == 0 ? "none was lost" : "some were lost (see index_overflow)";
      add_own(batch,
              EventRecord{host_now().ns, "index_behind", std::nullopt,
                          fmt::format("the index fell behind for {:.1f} s: {} records waited ({} of them on disk); {}",
                                      double(host_now().ns - behind_since_ns_.load()) / 1e9, waited - waited_reported_,
                                      spilled - spilled_reported_, outcome)});
      spdlog::info("session index: caught up; {} records waited for it ({} on disk); {}", waited - waited_reported_,
                   spilled - spilled_reported_, outcome);
      waited_reported_ = waited;
      spilled_reported_ = spilled;
    }
    if (const std::uint64_t lost = records_lost(); lost > lost_reported && !failed_.load()) {
      if (journal_) journal_->keep_all();  // the lost rows may be in it
      add_own(batch,
              EventRecord{host_now().ns, "index_overflow", std::nullopt,
                          fmt::format("{} index records were lost (so far: {}){}", lost - lost_reported,
                                      lost_records_by_kind(), overflow_.failure() ? ": " + *overflow_.failure() : "")});
      lost_reported = lost;
    }
    if (journal_ && !journal_reported) {
      if (auto f = journal_->failure()) {
        add_own(batch, EventRecord{host_now().ns, "index_journal", std::nullopt,
                                   fmt::format("the journal of rows not yet committed stopped: {}; rows waiting for "
                                               "the index after it would not survive a crash",
                                               *f)});
        journal_reported = true;
      }
    }
    if (done) break;
    if (!batch.empty() && std::chrono::steady_clock::now() - batch_started >= batch_period_) write_batch(batch);
  }
  write_batch(batch);
}

}  // namespace pvcap
