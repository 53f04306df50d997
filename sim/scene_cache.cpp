#include "sim/scene_cache.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "storage/video/frame_checksum.h"

namespace pvcap::sim {

namespace {
namespace fs = std::filesystem;
constexpr char kSceneMagic[8] = {'P', 'V', 'S', 'C', 'E', 'N', 'E', '1'};

// The running executable, as the key's first line: rebuilt, it names another file.
const std::string& executable_identity() {
  static const std::string id = [] {
    struct stat st {};
    if (stat("/proc/self/exe", &st) != 0) return std::string("exe unknown\n");
    return fmt::format("exe {}:{}:{}:{}.{}\n", st.st_dev, st.st_ino, st.st_size, st.st_mtim.tv_sec, st.st_mtim.tv_nsec);
  }();
  return id;
}

std::uint64_t scene_key_hash(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

template <typename T>
void append_raw(std::string& out, T v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

template <typename T>
bool read_raw(const std::string& in, std::size_t& at, T& v) {
  if (in.size() - at < sizeof v) return false;
  std::memcpy(&v, in.data() + at, sizeof v);
  at += sizeof v;
  return true;
}

std::optional<cv::Mat> read_scene(const fs::path& file, const std::string& key) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t at = sizeof kSceneMagic;
  if (bytes.size() < at || std::memcmp(bytes.data(), kSceneMagic, sizeof kSceneMagic) != 0) return std::nullopt;
  std::uint32_t key_size = 0;
  if (!read_raw(bytes, at, key_size) || bytes.size() - at < key_size || bytes.compare(at, key_size, key) != 0 ||
      key_size != key.size())
    return std::nullopt;
  at += key_size;
  std::int32_t rows = 0, cols = 0, type = 0;
  std::uint64_t size = 0;
  if (!read_raw(bytes, at, rows) || !read_raw(bytes, at, cols) || !read_raw(bytes, at, type) ||
      !read_raw(bytes, at, size))
    return std::nullopt;
  if (rows <= 0 || cols <= 0 || type < 0 || type >= CV_DEPTH_MAX * CV_CN_MAX) return std::nullopt;
  const std::uint64_t expected = std::uint64_t(rows) * std::uint64_t(cols) * CV_ELEM_SIZE(type);
  std::uint32_t crc = 0;
  if (size != expected || bytes.size() - at != size + sizeof crc) return std::nullopt;
  cv::Mat image(rows, cols, type);
  std::memcpy(image.data, bytes.data() + at, size);
  at += size;
  if (!read_raw(bytes, at, crc) || crc != crc32_of(image.data, size)) return std::nullopt;
  return image;
}

void write_scene(const fs::path& dir, const fs::path& file, const std::string& key, const cv::Mat& image) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return;
  const cv::Mat packed = image.isContinuous() ? image : image.clone();
  const std::uint64_t size = packed.total() * packed.elemSize();
  std::string head(kSceneMagic, sizeof kSceneMagic);
  append_raw(head, std::uint32_t(key.size()));
  head += key;
  append_raw(head, std::int32_t(packed.rows));
  append_raw(head, std::int32_t(packed.cols));
  append_raw(head, std::int32_t(packed.type()));
  append_raw(head, size);
  head.append(reinterpret_cast<const char*>(packed.data), size);
  append_raw(head, crc32_of(packed.data, size));
  // Written beside its name (file.tmp-PID) and renamed over it when whole: a reader finds the old
  // file, the new one or none, and two simulators writing the same scene at once both succeed.
  (void)write_file_atomically(file, head, Durability::Renamed);  // a cache: a failure costs a render
}

// Keeps the newest scenes within `budget` bytes (a read refreshes a scene's time), and removes what
// a simulator killed while writing left (its scene-*.bin.tmp-PID, an hour old).
void evict_old_scenes(const fs::path& dir, std::uintmax_t budget) {
  std::error_code ec;
  struct Scene {
    fs::file_time_type time;
    fs::path path;
    std::uintmax_t bytes;
  };
  std::vector<Scene> scenes;
  const auto an_hour_ago = fs::file_time_type::clock::now() - std::chrono::hours(1);
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    std::error_code tec;
    const auto t = e.last_write_time(tec);
    if (tec) continue;
    if (name.rfind("scene-", 0) == 0 && name.find(".bin.tmp-") != std::string::npos && t < an_hour_ago)
      fs::remove(e.path(), tec);
    if (name.rfind("scene-", 0) != 0 || e.path().extension() != ".bin") continue;
    const std::uintmax_t bytes = e.file_size(tec);
    if (!tec) scenes.push_back({t, e.path(), bytes});
  }
  std::sort(scenes.begin(), scenes.end(), [](const Scene& a, const Scene& b) { return a.time > b.time; });
  std::uintmax_t kept = 0;
  for (const Scene& s : scenes) {
    kept += s.bytes;
    if (kept > budget) fs::remove(s.path, ec);
  }
}
}  // namespace

std::optional<fs::path> scene_cache_dir() {
  if (const char* set = std::getenv("PVCAP_SIM_CACHE")) {
    const std::string v = set;
    if (v.empty() || v == "off") return std::nullopt;
    return fs::path(v);
  }
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return fs::path(xdg) / "pvcap" / "sim-scenes";
  if (const char* home = std::getenv("HOME"); home && *home) return fs::path(home) / ".cache" / "pvcap" / "sim-scenes";
  return std::nullopt;
}

cv::Mat cached_scene(const std::optional<fs::path>& dir, const std::string& key, const std::function<cv::Mat()>& render,
                     std::uintmax_t budget) {
  if (!dir) return render();
  const std::string full_key = executable_identity() + key;
  const fs::path file = *dir / fmt::format("scene-{:016x}.bin", scene_key_hash(full_key));
  if (auto image = read_scene(file, full_key)) {
    std::error_code ec;
    fs::last_write_time(file, fs::file_time_type::clock::now(), ec);
    return *image;
  }
  cv::Mat image = render();
  write_scene(*dir, file, full_key, image);
  evict_old_scenes(*dir, budget);
  return image;
}

}  // namespace pvcap::sim
