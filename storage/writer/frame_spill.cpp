#include "storage/writer/frame_spill.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>
#include <zlib.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "core/time.h"

namespace pvcap {

namespace {

// A frame that arrived at `arrived_host_ns` has just reached the kernel's files: the worst so far?
void note_age(FrameSpillQueue::DiskAge& worst, std::int64_t arrived_host_ns, bool via_spill) {
  const std::int64_t age = host_now().ns - arrived_host_ns;
  if (age > worst.worst_ns) worst = {age, arrived_host_ns, via_spill};
}

// Record: "PVS4", u32 total bytes, u32 CRC-32 of everything after it, then the fields below and the
// pixels. Little-endian (the machine's; a spill is read back by the same machine). "PVS3" records
// (pvcap before store version 7) are the same without the frame's line levels, "PVS2" records (before
// version 6) without its chunk data, "PVSP" records (before version 5) without its capture checksum too.
constexpr char kMagic[4] = {'P', 'V', 'S', '4'};
constexpr char kMagicWithoutLines[4] = {'P', 'V', 'S', '3'};
constexpr char kMagicWithoutChunks[4] = {'P', 'V', 'S', '2'};
constexpr char kMagicWithoutChecksum[4] = {'P', 'V', 'S', 'P'};
constexpr std::size_t kPrefix = 12;             // magic, size, CRC
constexpr std::uint32_t kMaxRecord = 1u << 30;  // a frame larger than 1 GiB is damage, not a frame

class Buffer {
 public:
  template <typename T>
  void put(const T& v) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void put_string(const std::string& s) {
    put(std::uint16_t(std::min<std::size_t>(s.size(), 0xffff)));
    bytes_.insert(bytes_.end(), s.begin(), s.begin() + std::min<std::size_t>(s.size(), 0xffff));
  }
  std::vector<std::uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

class Cursor {
 public:
  Cursor(const std::uint8_t* p, std::size_t n) : p_(p), n_(n) {}
  template <typename T>
  bool get(T& v) {
    if (n_ < sizeof(T)) return false;
    std::memcpy(&v, p_, sizeof(T));
    p_ += sizeof(T);
    n_ -= sizeof(T);
    return true;
  }
  bool get_string(std::string& s) {
    std::uint16_t len = 0;
    if (!get(len) || n_ < len) return false;
    s.assign(reinterpret_cast<const char*>(p_), len);
    p_ += len;
    n_ -= len;
    return true;
  }
  const std::uint8_t* at() const { return p_; }
  std::size_t left() const { return n_; }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
};

// The record's fields after the prefix, up to (not including) the pixels.
std::vector<std::uint8_t> fields(const SpillItem& item) {
  Buffer b;
  const FrameRecord& r = item.rec;
  b.put(r.device_id);
  b.put(r.connection);
  b.put(r.sequence);
  b.put(r.frame_id);
  b.put(r.device_ns);
  b.put(r.host_ns);
  b.put(r.aravis_system_ns);
  b.put(std::uint8_t(r.mapped_ns.has_value()));
  b.put(r.mapped_ns.value_or(0));
  b.put_string(r.status);
  b.put(std::uint8_t(r.checksum.has_value()));
  b.put(r.checksum.value_or(0));
  b.put(std::uint8_t((r.chunk_frame_counter ? 1 : 0) | (r.chunk_timestamp ? 2 : 0) | (r.chunk_exposure_us ? 4 : 0) |
                     (r.chunk_gain ? 8 : 0) | (r.chunk_line_status ? 16 : 0)));
  b.put(r.chunk_frame_counter.value_or(0));
  b.put(r.chunk_timestamp.value_or(0));
  b.put(r.chunk_exposure_us.value_or(0.0));
  b.put(r.chunk_gain.value_or(0.0));
  b.put(r.chunk_line_status.value_or(0));
  b.put(std::int32_t(item.image.rows));
  b.put(std::int32_t(item.image.cols));
  b.put(std::int32_t(item.image.type()));
  b.put(std::uint64_t(item.image.total() * item.image.elemSize()));
  return std::move(b.bytes());
}

// 0 when read whole; else the read's errno, or -1 when the file ends first.
int full_pread(int fd, void* buf, std::size_t n, std::int64_t off) {
  auto* p = static_cast<std::uint8_t*>(buf);
  while (n > 0) {
    const ssize_t got = ::pread(fd, p, n, off);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return errno;
    if (got == 0) return -1;
    p += got;
    n -= std::size_t(got);
    off += got;
  }
  return 0;
}

// Why a record could not be read: the disk's error, or where the file ends (a crash's cut).
Error unread(int why, const char* cut) {
  return Error{why > 0 ? fmt::format("cannot be read: {}", std::strerror(why)) : std::string(cut)};
}

// The record at `off`: its frame and its size in bytes; an Error when it is cut or damaged.
Result<std::pair<SpillRecord, std::size_t>> read_record(int fd, std::int64_t off) {
  std::uint8_t prefix[kPrefix];
  if (const int why = full_pread(fd, prefix, kPrefix, off)) return unread(why, "cut before its header");
  const bool with_lines = std::memcmp(prefix, kMagic, 4) == 0;
  const bool with_chunks = with_lines || std::memcmp(prefix, kMagicWithoutLines, 4) == 0;
  const bool with_checksum = with_chunks || std::memcmp(prefix, kMagicWithoutChunks, 4) == 0;
  if (!with_checksum && std::memcmp(prefix, kMagicWithoutChecksum, 4) != 0) return Error{"not a spill record"};
  std::uint32_t size = 0, crc = 0;
  std::memcpy(&size, prefix + 4, 4);
  std::memcpy(&crc, prefix + 8, 4);
  if (size < kPrefix || size > kMaxRecord) return Error{fmt::format("impossible record size {}", size)};
  // A damaged size is not believed before the file is seen to hold it (no buffer of a size a flipped
  // bit chose).
  struct stat st {};
  if (::fstat(fd, &st) != 0 || off + std::int64_t(size) > std::int64_t(st.st_size)) return Error{"cut in its body"};
  std::vector<std::uint8_t> body(size - kPrefix);
  if (const int why = full_pread(fd, body.data(), body.size(), off + std::int64_t(kPrefix)))
    return unread(why, "cut in its body");
  if (std::uint32_t(crc32(0L, body.data(), uInt(body.size()))) != crc) return Error{"CRC mismatch"};
  Cursor c(body.data(), body.size());
  SpillRecord out;
  FrameRecord& r = out.rec;
  std::uint8_t has_mapped = 0, has_checksum = 0, has_chunks = 0;
  std::int64_t mapped = 0, chunk_counter = 0, chunk_timestamp = 0, chunk_lines = 0;
  double chunk_exposure = 0, chunk_gain = 0;
  std::uint32_t checksum = 0;
  std::int32_t rows = 0, cols = 0, type = 0;
  std::uint64_t pixel_bytes = 0;
  if (!c.get(r.device_id) || !c.get(r.connection) || !c.get(r.sequence) || !c.get(r.frame_id) || !c.get(r.device_ns) ||
      !c.get(r.host_ns) || !c.get(r.aravis_system_ns) || !c.get(has_mapped) || !c.get(mapped) ||
      !c.get_string(r.status) || (with_checksum && (!c.get(has_checksum) || !c.get(checksum))) ||
      (with_chunks && (!c.get(has_chunks) || !c.get(chunk_counter) || !c.get(chunk_timestamp) ||
                       !c.get(chunk_exposure) || !c.get(chunk_gain))) ||
      (with_lines && !c.get(chunk_lines)) ||
      !c.get(rows) || !c.get(cols) || !c.get(type) || !c.get(pixel_bytes))
    return Error{"fields cut short"};
  if (has_mapped) r.mapped_ns = mapped;
  if (has_checksum) r.checksum = checksum;
  if (has_chunks & 1) r.chunk_frame_counter = chunk_counter;
  if (has_chunks & 2) r.chunk_timestamp = chunk_timestamp;
  if (has_chunks & 4) r.chunk_exposure_us = chunk_exposure;
  if (has_chunks & 8) r.chunk_gain = chunk_gain;
  if (has_chunks & 16) r.chunk_line_status = chunk_lines;
  if (rows <= 0 || cols <= 0 || rows > 65536 || cols > 65536 ||
      (type != CV_8UC1 && type != CV_8UC3 && type != CV_16UC1))
    return Error{fmt::format("impossible image {}x{} of type {}", cols, rows, type)};
  cv::Mat image(rows, cols, type);
  if (pixel_bytes != image.total() * image.elemSize() || c.left() != pixel_bytes)
    return Error{"pixel count does not match the image"};
  std::memcpy(image.data, c.at(), pixel_bytes);
  out.image = std::move(image);
  return std::make_pair(std::move(out), std::size_t(size));
}

}  // namespace

FrameSpillQueue::FrameSpillQueue(std::filesystem::path dir, std::string camera, std::size_t memory_frames,
                                 std::size_t writer_frames, std::chrono::milliseconds memory_age,
                                 std::chrono::milliseconds writer_age)
    : folder_(std::move(dir) / kSpillFolder),
      camera_(std::move(camera)),
      memory_cap_(memory_frames),
      writer_cap_(writer_frames),
      memory_age_(memory_age),
      writer_age_(writer_age),
      writer_([this] { writer_loop(); }) {}

FrameSpillQueue::~FrameSpillQueue() {
  {
    std::lock_guard lock(mu_);
    stop_writer_ = true;
    closed_ = true;
  }
  to_write_.notify_all();
  writer_.join();
  if (fd_ >= 0) ::close(fd_);  // what it holds stays for recover
}

bool FrameSpillQueue::push(cv::Mat image, FrameRecord rec) {
  std::lock_guard lock(mu_);
  if (closed_ || abandoned_) return false;
  const auto now = std::chrono::steady_clock::now();
  const bool spilling = !for_writer_.empty() || writing_ || on_disk_ > 0;
  const bool stale = !memory_.empty() && now - memory_.front().pushed > memory_age_;
  if (!spilling && memory_.size() < memory_cap_ && !stale) {
    memory_.push_back({std::move(image), std::move(rec), "", false, now});
    ready_.notify_one();
    return true;
  }
  // Behind: from here on, every frame goes through the disk until the encoder has caught up.
  if (failure_ || memory_.size() + for_writer_.size() >= memory_cap_ + writer_cap_) return false;
  if (!for_writer_.empty() && now - for_writer_.front().pushed > writer_age_) return false;
  if (!spilling) memory_to_spill();
  for_writer_.push_back({std::move(image), std::move(rec), "", false, now});
  ++spilled_;
  to_write_.notify_one();
  return true;
}

void FrameSpillQueue::memory_to_spill() {
  // The frames waiting in memory go first (they are older), so that a power cut cannot take them
  // while the encoder is held up; the memory they hold is the same, now in the writer's queue. The
  // one in the encoder's hands goes too: when the encoder has written it, its spilled copy is skipped.
  spilled_ += memory_.size();
  for (auto& item : memory_) for_writer_.push_back(std::move(item));
  memory_.clear();
  to_write_.notify_one();
}

void FrameSpillQueue::spill_stale_memory() {
  const bool spilling = !for_writer_.empty() || writing_ || on_disk_ > 0;
  if (spilling || failure_ || memory_.empty()) return;
  if (std::chrono::steady_clock::now() - memory_.front().pushed > memory_age_) memory_to_spill();
}

Status FrameSpillQueue::append(const SpillItem& item) {
  std::vector<std::uint8_t> head(kPrefix);
  std::vector<std::uint8_t> body = fields(item);
  const cv::Mat pixels = item.image.isContinuous() ? item.image : item.image.clone();
  const std::size_t pixel_bytes = pixels.total() * pixels.elemSize();
  const std::uint32_t size = std::uint32_t(kPrefix + body.size() + pixel_bytes);
  uLong crc = crc32(0L, body.data(), uInt(body.size()));
  crc = crc32(crc, pixels.data, uInt(pixel_bytes));
  std::memcpy(head.data(), kMagic, 4);
  std::memcpy(head.data() + 4, &size, 4);
  const std::uint32_t crc32v = std::uint32_t(crc);
  std::memcpy(head.data() + 8, &crc32v, 4);
  iovec parts[3] = {{head.data(), head.size()}, {body.data(), body.size()}, {pixels.data, pixel_bytes}};
  std::size_t done = 0;
  while (done < size) {
    // Skip what is already written, then write the rest.
    iovec rest[3];
    int n = 0;
    std::size_t skip = done;
    for (const iovec& p : parts) {
      if (skip >= p.iov_len) {
        skip -= p.iov_len;
        continue;
      }
      rest[n++] = {static_cast<std::uint8_t*>(p.iov_base) + skip, p.iov_len - skip};
      skip = 0;
    }
    const ssize_t w = ::pwritev(fd_, rest, n, write_off_ + std::int64_t(done));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return Error{fmt::format("{}: cannot write the spill: {}", file_.string(), std::strerror(errno))};
    done += std::size_t(w);
  }
  write_off_ += size;
  return {};
}

void FrameSpillQueue::writer_loop() {
  std::unique_lock lock(mu_);
  for (;;) {
    // Awake at least every 50 ms: a frame's age in memory is kept to also when no frame comes to
    // push it out (the cameras stopped, or one went quiet) and the encoder is held up.
    to_write_.wait_for(lock, std::chrono::milliseconds(50), [&] { return stop_writer_ || !for_writer_.empty(); });
    spill_stale_memory();
    if (for_writer_.empty()) {
      if (stop_writer_) return;  // stopping, nothing left
      continue;
    }
    SpillItem item = std::move(for_writer_.front());
    for_writer_.pop_front();
    writing_ = true;
    Status status;
    if (fd_ < 0) {  // a new spill episode: a new file (quick; under the lock so the reader sees it whole)
      std::error_code ec;
      std::filesystem::create_directories(folder_, ec);
      file_ = folder_ / fmt::format("{}-{:04}.spill", camera_, next_file_++);
      fd_ = ::open(file_.c_str(), O_CREAT | O_RDWR | O_TRUNC | O_CLOEXEC, 0644);
      if (fd_ < 0)
        status = Error{fmt::format("{}: cannot create the spill file: {}", file_.string(), std::strerror(errno))};
      write_off_ = read_off_ = 0;
    }
    const bool halted = halt_ && halt_->load();
    if (status.ok() && !halted) {
      lock.unlock();
      status = append(item);
      lock.lock();
    }
    writing_ = false;
    if (halted) {  // another of the session's writes failed: this frame's bytes would take the index's room
      item.lost_reason = "storage_failed";
      item.image.release();
      lost_.push_back(std::move(item));
    } else if (status.ok()) {
      ++on_disk_;
      note_age(disk_age_, item.rec.host_ns, true);
    } else {
      if (!failure_) failure_ = status.error().message;
      if (halt_) halt_->store(true);
      item.lost_reason = "spill_write_failed";
      item.image.release();
      lost_.push_back(std::move(item));
    }
    ready_.notify_all();
  }
}

FrameSpillQueue::DiskAge FrameSpillQueue::worst_disk_age() const {
  std::lock_guard lock(mu_);
  return disk_age_;
}

std::optional<SpillItem> FrameSpillQueue::pop_for(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mu_);
  if (in_hand_host_ns_) done_with(*in_hand_host_ns_);  // the encoder asks for the next: done with the last
  const auto nothing_left = [&] {
    return memory_.empty() && lost_.empty() && for_writer_.empty() && !writing_ && on_disk_ == 0;
  };
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    ready_.wait_until(lock, deadline, [&] {
      return !lost_.empty() || !memory_.empty() || on_disk_ > 0 || (closed_ && nothing_left());
    });
    if (!lost_.empty()) {
      SpillItem item = std::move(lost_.front());
      lost_.pop_front();
      return item;
    }
    if (!memory_.empty()) {  // memory frames are older than anything spilled
      // It stays in memory until the encoder has written it (written()), so that the age rule can
      // still send it to the spill if the encoder is held up with it in hand. The encoder gets the
      // same pixels (neither side changes them).
      const SpillItem& front = memory_.front();
      in_hand_host_ns_ = front.rec.host_ns;
      return SpillItem{front.image, front.rec, "", false, front.pushed};
    }
    if (on_disk_ == 0) return std::nullopt;  // the timeout, or closed with nothing left
    const int fd = fd_;
    const std::int64_t off = read_off_;
    lock.unlock();  // the writer appends beyond `off` meanwhile
    auto got = read_record(fd, off);
    lock.lock();
    if (!got) return read_back_failed(got.error().message);
    read_off_ += std::int64_t(got.value().second);
    --on_disk_;
    if (on_disk_ == 0 && for_writer_.empty() && !writing_) {
      // Caught up: this episode's file is done; back to memory for the next frames.
      ::close(fd_);
      fd_ = -1;
      finished_files_.push_back(file_);
    }
    // A frame the encoder had in hand when it went to the spill, and has written since: once is
    // enough; wait (within the timeout) for the next one, which the writer may still be appending.
    if (got.value().first.rec.host_ns <= written_through_host_ns_) continue;
    return SpillItem{std::move(got.value().first.image), std::move(got.value().first.rec), "", true};
  }
}

void FrameSpillQueue::written(const SpillItem& item) {
  std::lock_guard lock(mu_);
  if (!item.from_spill && item.lost_reason.empty() && in_hand_host_ns_ == item.rec.host_ns) done_with(item.rec.host_ns);
}

void FrameSpillQueue::done_with(std::int64_t host_ns) {
  in_hand_host_ns_.reset();
  written_through_host_ns_ = std::max(written_through_host_ns_, host_ns);
  if (!memory_.empty() && memory_.front().rec.host_ns == host_ns) {
    memory_.pop_front();
    note_age(disk_age_, host_ns, false);  // still in memory: it reached the disk in its video
  }
}

std::optional<SpillItem> FrameSpillQueue::read_back_failed(const std::string& why) {
  // Written by us a moment ago and unreadable now: the disk failed. What is left in this file stays
  // for recover; the frames are not handed out (their rows come from recover).
  // The file stays open (the writer may be appending to it this moment); failure_ makes push()
  // refuse further frames, so the queue still drains and closes.
  if (!failure_)
    failure_ = fmt::format("{}: a spilled frame cannot be read back ({}); recover finishes it", file_.string(), why);
  on_disk_ = 0;
  return std::nullopt;
}

void FrameSpillQueue::close() {
  {
    std::lock_guard lock(mu_);
    closed_ = true;
  }
  ready_.notify_all();
}

std::vector<SpillItem> FrameSpillQueue::abandon() {
  std::lock_guard lock(mu_);
  abandoned_ = true;
  std::vector<SpillItem> lost;
  for (auto* from : {&lost_, &memory_, &for_writer_})
    for (auto& item : *from) {
      if (item.lost_reason.empty()) item.lost_reason = "storage_failed";
      item.image.release();
      lost.push_back(std::move(item));
    }
  lost_.clear();
  memory_.clear();
  for_writer_.clear();
  in_hand_host_ns_.reset();
  ready_.notify_all();
  return lost;
}

void FrameSpillQueue::share_halt(std::shared_ptr<std::atomic<bool>> halt) {
  std::lock_guard lock(mu_);
  halt_ = std::move(halt);
}

bool FrameSpillQueue::drained() const {
  std::lock_guard lock(mu_);
  if (abandoned_) return true;
  return closed_ && memory_.empty() && lost_.empty() && for_writer_.empty() && !writing_ && on_disk_ == 0;
}

bool FrameSpillQueue::is_closed() const {
  std::lock_guard lock(mu_);
  return closed_;
}

void FrameSpillQueue::release_finished() {
  std::vector<std::filesystem::path> files;
  {
    std::lock_guard lock(mu_);
    files.swap(finished_files_);
  }
  std::error_code ec;
  for (const auto& f : files) std::filesystem::remove(f, ec);
}

std::size_t FrameSpillQueue::backlog() const {
  std::lock_guard lock(mu_);
  return memory_.size() + for_writer_.size() + (writing_ ? 1 : 0) + on_disk_;
}

std::size_t FrameSpillQueue::on_disk() const {
  std::lock_guard lock(mu_);
  return on_disk_ + for_writer_.size() + (writing_ ? 1 : 0);
}

std::uint64_t FrameSpillQueue::spilled_total() const {
  std::lock_guard lock(mu_);
  return spilled_;
}

std::optional<std::string> FrameSpillQueue::failure() const {
  std::lock_guard lock(mu_);
  return failure_;
}

Result<std::size_t> read_spill_file(const std::filesystem::path& file, const std::function<void(SpillRecord&&)>& each) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error{fmt::format("{}: cannot open: {}", file.string(), std::strerror(errno))};
  std::size_t n = 0;
  std::int64_t off = 0;
  for (;;) {
    auto got = read_record(fd, off);
    if (!got) {
      std::uint8_t probe;
      const bool at_end = ::pread(fd, &probe, 1, off) == 0;
      if (n == 0 && !at_end && got.error().message == "not a spill record") {
        ::close(fd);
        return Error{fmt::format("{}: not a pvcap spill file", file.string())};
      }
      if (got.error().message.rfind("cannot be read", 0) == 0) {  // the disk's error, not a cut tail
        ::close(fd);
        return Error{fmt::format("{}: {}", file.string(), got.error().message)};
      }
      break;  // the end, or a crash's cut tail
    }
    off += std::int64_t(got.value().second);
    ++n;
    each(std::move(got.value().first));
  }
  ::close(fd);
  return n;
}

}  // namespace pvcap
