#pragma once
// Runs the real `pvcap` command on a simulated rig and reads back what it
// stored and what the simulator says really happened (sim-truth/).
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace pvcap::testing {

struct SimCameraSpec {
  double packet_loss = 0;
  double stop_after_s = -1;    // < 0: never
  double return_after_s = -1;  // < 0: never
  int outages = 1;              // that outage again every outage_every_s, this many times in all
  double outage_every_s = 0;
  bool trigger_line = true;    // false: not wired to the simulated trigger line
  double drift_ppm = 0;
  double offset_ms = 1000;  // fields are set by name in the tests ({.packet_loss = 0.01})
  std::string node_map;     // "sfnc2": its node map in SFNC 2's names (sim/fake_camera_features.h)
  bool white_balance_auto = false;
  std::string sim_keys;  // more of its sim: entry's keys, as YAML flow ("ptp_lock_after_s: 2, ptp_servo_error_ns: 40")
};

// A rig of `cameras` simulated cameras at 127.0.0.2.. with the given size and rate.
std::string sim_rig_yaml(const std::vector<SimCameraSpec>& cameras, int width, int height, double fps, double video_fps,
                         const std::string& trigger = "free-run", bool sensel = false);

// A protocol of one press (index finger) at the given force levels ("[low, high]"), 2 repetitions,
// with the given fast timings; written as dir/protocol.yaml. `hands` ("[right]") limits it to one
// hand; empty: both.
std::filesystem::path write_press_protocol(const std::filesystem::path& dir, const std::string& forces, double prompt_s,
                                           double countdown_s, double record_s, double rest_s,
                                           const std::string& hands = "");
// Four 320x240 cameras at 30 Hz and a Sensel: the protocol tests' rig, written as dir/rig.yaml.
std::filesystem::path write_protocol_rig(const std::filesystem::path& dir);

// The simulator's lenses (its truth, without the pads' poses) as a rig calibration file at `file`:
// what a board session would have measured, so a test can calibrate the pad without one. Empty
// string on success, else what went wrong.
std::string write_truth_lenses(const std::filesystem::path& session, const std::filesystem::path& file);

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};
// `prefix` runs pvcap through another command (e.g. nsenter into a session's network namespace).
CommandResult run_pvcap(const std::string& args, const std::string& prefix = "");
// Starts `pvcap ARGS` in the background with its output going to `log`; returns its pid.
// `prefix` runs it through another command that execs it (e.g. "ip netns exec NAME").
pid_t spawn_pvcap(const std::string& args, const std::filesystem::path& log, const std::string& prefix = "");
std::string read_all(const std::filesystem::path& p);
// Every file under `dir` (relative path) with its SHA-256: what a command that must change nothing
// compares before and after. `without_sqlite_sidecars` leaves out session.db-wal and -shm (a reader,
// such as verify, may leave them; the index's content is session.db's once its last writer closed).
std::map<std::string, std::string> folder_hashes(const std::filesystem::path& dir,
                                                 bool without_sqlite_sidecars = false);
// A fresh, empty folder for one test's files: <tmp>/pvcap-it-<name>-<pid>. It is removed when the
// test ends, also when an assertion or a failure ends it early (what a test records is a session's
// size, and /tmp is shared); with PVCAP_KEEP_FAILED=1 a failed test's folders are kept and named.
std::filesystem::path work_dir(const std::string& name);
// The same for a folder the tests of this process share (a fixture recorded once): removed when
// the process ends.
std::filesystem::path process_work_dir(const std::string& name);
// The one session folder pvcap made under `root` (not the simulator's .sim-truth-* while it runs);
// empty when there is none.
std::filesystem::path only_session(const std::filesystem::path& root);
// Waits until `log` contains `needle`; false after `timeout`.
bool wait_for_text(const std::filesystem::path& log, const std::string& needle, std::chrono::seconds timeout);
// The most seconds of recording `pvcap session`'s progress lines ("   6.1 s | cam0 ...") show in
// `text`; 0 before the first. (A line is printed every ~2 s, its time the session's own, so a
// test waits for "at least", never for one exact figure.)
double recorded_seconds_shown(const std::string& text);
// Waits until `log` shows at least `seconds` of recording; false after `timeout`.
bool wait_for_recorded_seconds(const std::filesystem::path& log, double seconds, std::chrono::seconds timeout);

struct TruthFrame {
  std::uint16_t frame_id;
  std::int64_t true_ns, device_ns;
};
struct IndexFrame {
  std::uint32_t connection;
  std::uint64_t sequence, frame_id;
  std::int64_t device_ns, host_ns;
  std::string status, reason;
  bool kept;
  std::int64_t video_index;  // -1 when not in the video
  std::int64_t video_file_id = -1;
};
struct DropRange {
  std::uint64_t first_sequence, count;
  std::string reason;
};
struct CameraRecord {
  std::string name;
  std::int64_t device_id = 0;
  std::vector<TruthFrame> truth;
  std::vector<IndexFrame> frames;  // in arrival order
  std::vector<DropRange> drops;
  std::vector<std::pair<std::int64_t, std::filesystem::path>> videos;  // (video file id, path) by segment
};

struct RecordedSession {
  CommandResult result;
  std::filesystem::path dir;  // the session folder
  std::vector<CameraRecord> cameras;
};

// Writes the rig to a fresh work folder, runs `pvcap session` for `duration_s`, loads the outcome.
RecordedSession record(const std::string& test_name, const std::string& rig_yaml, double duration_s);

// GigE Vision 1.x frame id of an unwrapped sequence number (ids run 1..65535).
inline std::uint16_t frame_id_of_sequence(std::uint64_t seq) { return std::uint16_t((seq - 1) % 65535 + 1); }

}  // namespace pvcap::testing
