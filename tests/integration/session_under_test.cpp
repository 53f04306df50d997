#include "session_under_test.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "calib/rig_calibration.h"
#include "export/sha256.h"
#include "sim/truth.h"
#include "storage/index/database.h"

namespace fs = std::filesystem;

namespace pvcap::testing {

std::string sim_rig_yaml(const std::vector<SimCameraSpec>& cameras, int width, int height, double fps, double video_fps,
                         const std::string& trigger, bool sensel) {
  std::string y = "name: test-rig\ncameras:\n";
  for (std::size_t i = 0; i < cameras.size(); ++i)
    y += fmt::format(
        "  - name: cam{0}\n    serial: PVSIM{0}\n    address: 127.0.0.{1}\n    width: {2}\n    height: {3}\n"
        "    frame_rate: {4}\n    packet_size: 8192\n    trigger: {5}\n",
        i, i + 2, width, height, fps, trigger);
  if (sensel) y += "sensel:\n  tty: sim\n  scan_detail: medium\n";
  y += fmt::format("store:\n  video_fps: {}\n  preset: ultrafast\nsim:\n  seed: 11\n", video_fps);
  if (sensel) y += "  sensel: {press_x_mm: 100, press_y_mm: 60, peak_grams: 250, period_s: 1.0}\n";
  y += "  cameras:\n";
  for (const auto& c : cameras) {
    y += fmt::format("    - {{clock_offset_ms: {}, drift_ppm: {}, jitter_us: 10, packet_loss: {}", c.offset_ms,
                     c.drift_ppm, c.packet_loss);
    if (c.stop_after_s >= 0) y += fmt::format(", stop_after_s: {}", c.stop_after_s);
    if (c.return_after_s >= 0) y += fmt::format(", return_after_s: {}", c.return_after_s);
    if (c.outages > 1) y += fmt::format(", outages: {}, outage_every_s: {}", c.outages, c.outage_every_s);
    if (!c.trigger_line) y += ", trigger_line: false";
    if (!c.node_map.empty()) y += ", node_map: " + c.node_map;
    if (c.white_balance_auto) y += ", white_balance_auto: true";
    if (!c.sim_keys.empty()) y += ", " + c.sim_keys;
    y += "}\n";
  }
  return y;
}

CommandResult run_pvcap(const std::string& args, const std::string& prefix) {
  CommandResult r;
  const std::string cmd = prefix + (prefix.empty() ? "" : " ") + PVCAP_BIN + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  while (std::size_t n = fread(buf.data(), 1, buf.size(), p)) r.output.append(buf.data(), n);
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

pid_t spawn_pvcap(const std::string& args, const fs::path& log, const std::string& prefix) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string cmd = fmt::format("exec {} {} {} > {} 2>&1", prefix, PVCAP_BIN, args, log.string());
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

fs::path write_press_protocol(const fs::path& dir, const std::string& forces, double prompt_s, double countdown_s,
                              double record_s, double rest_s, const std::string& hands) {
  // A protocol's pictograms live in its own folder (protocol/protocol.cpp refuses others).
  fs::create_directories(dir / "pictograms");
  fs::copy_file(fs::path(PVCAP_SOURCE_DIR) / "rig-configs/protocols/pictograms/press_index_finger.svg",
                dir / "pictograms" / "press_index_finger.svg", fs::copy_options::overwrite_existing);
  std::ofstream(dir / "protocol.yaml") << fmt::format(
      "name: test\n"
      "fast_timings: {{prompt_s: {}, countdown_s: {}, record_s: {}, rest_s: {}}}\n"
      "actions:\n"
      "  - {{name: press_index_finger, text: Press with your index finger, pictogram: "
      "pictograms/press_index_finger.svg,\n"
      "      forces: {}, repetitions: 2{}}}\n",
      prompt_s, countdown_s, record_s, rest_s, forces, hands.empty() ? "" : ", hands: " + hands);
  return dir / "protocol.yaml";
}

fs::path write_protocol_rig(const fs::path& dir) {
  std::ofstream(dir / "rig.yaml") << sim_rig_yaml({{}, {}, {}, {}}, 320, 240, 30, 15, "free-run", /*sensel=*/true);
  return dir / "rig.yaml";
}

namespace {
fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / fmt::format("pvcap-it-{}-{}", name, getpid());
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Removes the folders work_dir() made for a test when it ends, however it ends.
class WorkDirRemover : public ::testing::EmptyTestEventListener {
 public:
  void add(const fs::path& d) { dirs_.push_back(d); }

 private:
  void OnTestEnd(const ::testing::TestInfo& test) override {
    const bool keep = test.result()->Failed() && std::getenv("PVCAP_KEEP_FAILED");
    for (const auto& d : dirs_) {
      if (keep) {
        std::printf("PVCAP_KEEP_FAILED: kept %s\n", d.c_str());
        continue;
      }
      std::error_code ignored;
      fs::remove_all(d, ignored);
    }
    dirs_.clear();
  }
  std::vector<fs::path> dirs_;
};
}  // namespace

fs::path work_dir(const std::string& name) {
  // Registered at the first call, inside a test (gtest owns and deletes its listeners).
  static WorkDirRemover* const remover = [] {
    auto* r = new WorkDirRemover;
    ::testing::UnitTest::GetInstance()->listeners().Append(r);
    return r;
  }();
  const fs::path d = fresh_dir(name);
  remover->add(d);
  return d;
}

fs::path process_work_dir(const std::string& name) {
  static std::vector<fs::path> dirs;
  if (dirs.empty())
    std::atexit([] {
      for (const auto& d : dirs) {
        std::error_code ignored;
        fs::remove_all(d, ignored);
      }
    });
  dirs.push_back(fresh_dir(name));
  return dirs.back();
}

fs::path only_session(const fs::path& root) {
  for (const auto& e : fs::directory_iterator(root))
    if (e.is_directory() && e.path().filename().string()[0] != '.') return e.path();
  return {};
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::map<std::string, std::string> folder_hashes(const std::filesystem::path& dir, bool without_sqlite_sidecars) {
  std::map<std::string, std::string> out;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || (without_sqlite_sidecars && (name == "session.db-wal" || name == "session.db-shm")))
      continue;
    auto h = pvcap::exporting::sha256_file(e.path());
    out[std::filesystem::relative(e.path(), dir).string()] = h ? h.value() : "unreadable: " + h.error().message;
  }
  return out;
}

bool wait_for_text(const fs::path& log, const std::string& needle, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (read_all(log).find(needle) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

double recorded_seconds_shown(const std::string& text) {
  double most = 0;
  for (auto bar = text.find(" s | "); bar != std::string::npos; bar = text.find(" s | ", bar + 1)) {
    auto start = bar;
    while (start > 0 && (std::isdigit(static_cast<unsigned char>(text[start - 1])) || text[start - 1] == '.')) --start;
    if (start < bar) most = std::max(most, std::atof(text.substr(start, bar - start).c_str()));
  }
  return most;
}

bool wait_for_recorded_seconds(const fs::path& log, double seconds, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (recorded_seconds_shown(read_all(log)) >= seconds) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

namespace {
std::vector<TruthFrame> read_truth(const fs::path& csv) {
  std::vector<TruthFrame> out;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    TruthFrame t{};
    unsigned fid = 0;
    if (std::sscanf(line.c_str(), "%u,%ld,%ld", &fid, &t.true_ns, &t.device_ns) == 3) {
      t.frame_id = std::uint16_t(fid);
      out.push_back(t);
    }
  }
  return out;
}
}  // namespace

RecordedSession record(const std::string& test_name, const std::string& rig_yaml, double duration_s) {
  RecordedSession s;
  const fs::path work = work_dir(test_name);  // removed when the test ends (kept if it failed, on request)
  std::ofstream(work / "rig.yaml") << rig_yaml;
  s.result = run_pvcap(fmt::format("session --rig {} --root {} --duration {}", (work / "rig.yaml").string(),
                                   (work / "sessions").string(), duration_s));
  if (!fs::exists(work / "sessions")) return s;
  for (const auto& e : fs::directory_iterator(work / "sessions"))
    if (e.is_directory() && e.path().filename().string()[0] != '.') s.dir = e.path();
  if (s.dir.empty()) return s;

  sqlite::Database db(s.dir / "session.db", sqlite::Database::Mode::ReadOnly);
  auto devs = db.prepare("SELECT id, name FROM devices WHERE kind = 'camera' ORDER BY id");
  while (devs.step()) {
    CameraRecord c;
    c.device_id = devs.column_int(0);
    c.name = devs.column_text(1);
    c.truth = read_truth(s.dir / "sim-truth" / (c.name + "_frames.csv"));
    auto f = db.prepare(
        "SELECT connection, sequence, frame_id, device_ns, host_ns, status, coalesce(reason, ''), kept, "
        "coalesce(video_index, -1), coalesce(video_file_id, -1) "
        "FROM frames WHERE device_id = ? ORDER BY host_ns");
    f.bind(1, c.device_id);
    while (f.step())
      c.frames.push_back({std::uint32_t(f.column_int(0)), std::uint64_t(f.column_int(1)),
                          std::uint64_t(f.column_int(2)), f.column_int(3), f.column_int(4), f.column_text(5),
                          f.column_text(6), f.column_int(7) != 0, f.column_int(8), f.column_int(9)});
    auto v = db.prepare("SELECT id, path FROM video_files WHERE device_id = ? ORDER BY segment");
    v.bind(1, c.device_id);
    while (v.step()) c.videos.emplace_back(v.column_int(0), s.dir / v.column_text(1));
    auto d = db.prepare("SELECT first_sequence, count, reason FROM drops WHERE device_id = ?");
    d.bind(1, c.device_id);
    while (d.step())
      c.drops.push_back({std::uint64_t(d.column_int(0)), std::uint64_t(d.column_int(1)), d.column_text(2)});
    s.cameras.push_back(std::move(c));
  }
  return s;
}

std::string write_truth_lenses(const std::filesystem::path& session, const std::filesystem::path& file) {
  auto truth = pvcap::sim::read_rig_truth(session / "sim-truth");
  if (!truth) return truth.error().message;
  pvcap::calib::RigCalibration lenses;
  lenses.rig = "sim-rig";
  for (const auto& c : truth.value().cameras) {
    pvcap::calib::CameraCalibration cc;
    cc.name = c.name;
    cc.model.image_size = c.model.image_size;
    cc.model.K = c.model.K;
    cc.model.distortion = c.model.distortion;
    cc.intrinsics = pvcap::calib::MeasuredBy{"truth", "", 0, 0.0};
    lenses.cameras.push_back(cc);
  }
  auto saved = pvcap::calib::save_rig_calibration(file, lenses);
  return saved.ok() ? std::string() : saved.error().message;
}

}  // namespace pvcap::testing

namespace {

// Each test process ends by printing the CPU it and the processes it waited for used, beside its wall
// time: what tells a test that waits on the clock (a session recorded in real time) from one that
// keeps the cores busy (docs/testing.md, "How the suite is scheduled", weighs the lanes by it).
class CpuTimePrinter : public ::testing::Environment {
 public:
  void SetUp() override { start_ = std::chrono::steady_clock::now(); }
  void TearDown() override {
    rusage self{}, children{};
    getrusage(RUSAGE_SELF, &self);
    getrusage(RUSAGE_CHILDREN, &children);
    const auto seconds = [](const timeval& a, const timeval& b) {
      return double(a.tv_sec + b.tv_sec) + double(a.tv_usec + b.tv_usec) / 1e6;
    };
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double cpu = seconds(self.ru_utime, children.ru_utime) + seconds(self.ru_stime, children.ru_stime);
    std::printf("[ cpu ] %.1f s of CPU in %.1f s (%.2f cores)\n", cpu, wall, wall > 0 ? cpu / wall : 0.0);
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

[[maybe_unused]] const auto* const kCpuTimePrinter = ::testing::AddGlobalTestEnvironment(new CpuTimePrinter);

// The simulators the tests start keep their rendered scenes in the build tree (sim/scene_cache.h):
// rendered once per build instead of once per session (~1.4 s of a core each), and gone with the
// build, not left in the home folder. At most 256 MB (a 1080p Bayer scene is 2 MB).
class SimSceneCache : public ::testing::Environment {
 public:
  void SetUp() override { setenv("PVCAP_SIM_CACHE", PVCAP_BINARY_DIR "/test-fixtures/sim-scenes", 0); }
};

[[maybe_unused]] const auto* const kSimSceneCache = ::testing::AddGlobalTestEnvironment(new SimSceneCache);

}  // namespace
