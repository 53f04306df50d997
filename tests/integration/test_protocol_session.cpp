// The participant session end to end on the simulated rig: the real `pvcap session`
// with a protocol, the automatic participant performing each take, the takes read
// back from the store; a session killed mid-protocol and resumed.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>

#include <fstream>
#include <map>
#include <regex>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "session_under_test.h"
#include "storage/index/session_reader.h"

namespace fs = std::filesystem;
using namespace pvcap::testing;

namespace {

// Three force levels of one press, with each hand: six takes of ~3 s.
fs::path write_protocol(const fs::path& dir) {
  return write_press_protocol(dir, "[low, high, no_contact]", 0.5, 0.4, 2.0, 0.3);
}
fs::path write_rig(const fs::path& dir) { return write_protocol_rig(dir); }

// The session folder under `root` that is not `except` (a resumed session's second folder).
fs::path session_other_than(const fs::path& root, const fs::path& except) {
  for (const auto& e : fs::directory_iterator(root))
    if (e.is_directory() && e.path().filename().string()[0] != '.' && e.path() != except) return e.path();
  return {};
}

nlohmann::json takes_of(const fs::path& session) {
  const auto r = run_pvcap(fmt::format("--log-level warn takes {} --json", session.string()));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return nlohmann::json::parse(r.output, nullptr, false);
}

}  // namespace

TEST(ProtocolSession, TheAutomaticParticipantPerformsEveryTakeAndTheDataAgreeWithTheLabels) {
  const fs::path work = work_dir("protocol");
  const auto r =
      run_pvcap(fmt::format("session --rig {} --root {} --protocol {} --auto --fast --participant T01 --skin-tone dark "
                            "--hand-order left_first",
                            write_rig(work).string(), (work / "sessions").string(), write_protocol(work).string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("ended: protocol complete"), std::string::npos) << r.output;
  const fs::path session = only_session(work / "sessions");
  const auto t = takes_of(session);
  ASSERT_TRUE(t.is_object());
  EXPECT_EQ(t["plan_steps"], 6);
  const auto& takes = t["takes"];
  ASSERT_EQ(takes.size(), 6u) << t.dump(1);
  const std::vector<std::string> forces = {"low", "high", "no_contact"};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(takes[i]["status"], "done") << takes[i].dump();
    EXPECT_EQ(takes[i]["step"], int(i));
    EXPECT_EQ(takes[i]["hand"], i < 3 ? "left" : "right") << "left first, as the participant's hand order says";
    EXPECT_EQ(takes[i]["force"], forces[i % 3]);
    EXPECT_EQ(takes[i]["sequence"],
              fmt::format("press_index_finger_{}_2x_{}", forces[i % 3], i < 3 ? "left" : "right"));
    EXPECT_EQ(takes[i]["check_ok"], true) << takes[i].dump();
    // The take spans its samples (2 s at 15 Hz) and its pressure frames: ~250 at 125 Hz, fewer when
    // ctest's load delays the driver's polls (a polled Morph scans when asked), but always many more
    // than the samples.
    EXPECT_NEAR(takes[i]["end_sample"].get<double>() - takes[i]["first_sample"].get<double>(), 30, 3);
    EXPECT_GT(takes[i]["pressure_frames"].get<int>(), 60);
  }
  // The data agree with the labels: High above Low above No contact (nothing).
  const auto& f = t["by_force"];
  const double high = f["high"]["mean_newtons"], low = f["low"]["mean_newtons"], none = f["no_contact"]["mean_newtons"];
  EXPECT_GT(high, 1.5 * low);
  EXPECT_GT(low, 0.3);
  EXPECT_LT(none, 0.01);
  // Where the simulated hand really pressed: each hand's takes on its own half (the truth's commands).
  std::ifstream hand(session / "sim-truth" / "hand.csv");
  std::string line;
  int presses = 0, hovers = 0;
  while (std::getline(hand, line)) {
    presses += line.find(" press ") != std::string::npos;
    hovers += line.find(" hover ") != std::string::npos;
  }
  EXPECT_EQ(presses, 4);
  EXPECT_EQ(hovers, 2);
  // The store holds the whole protocol, and reads back clean or lossy, never broken.
  const auto v = run_pvcap("verify " + session.string());
  EXPECT_TRUE(v.exit_code == 0 || v.exit_code == 3) << v.output;
}

TEST(ProtocolSession, AKilledSessionResumesAndTogetherTheFoldersCoverTheProtocol) {
  const fs::path work = work_dir("resume");
  const fs::path rig = write_rig(work), protocol = write_protocol(work), log = work / "first.log";
  const pid_t pid = spawn_pvcap(fmt::format("session --rig {} --root {} --protocol {} --auto --fast --participant "
                                            "T02 --hand-order right_first",
                                            rig.string(), (work / "sessions").string(), protocol.string()),
                                log);
  // Killed while the fourth take records: three were acknowledged (their end committed).
  ASSERT_TRUE(wait_for_text(log, "protocol: recording press_index_finger_low_2x_left", std::chrono::seconds(90)))
      << read_all(log);
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  ASSERT_EQ(kill(pid, SIGKILL), 0);
  int status = 0;
  waitpid(pid, &status, 0);
  const std::string first_log = read_all(log);
  std::set<std::string> acknowledged;
  const std::regex done_line("protocol: (press_index_finger_\\w+) done");
  for (auto it = std::sregex_iterator(first_log.begin(), first_log.end(), done_line); it != std::sregex_iterator();
       ++it)
    acknowledged.insert((*it)[1]);
  ASSERT_EQ(acknowledged.size(), 3u) << first_log;

  const fs::path first = only_session(work / "sessions");
  const auto rec = run_pvcap("recover " + first.string());
  ASSERT_EQ(rec.exit_code, 0) << rec.output;
  const auto resumed = run_pvcap(fmt::format("session --rig {} --resume {}", rig.string(), first.string()));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("resuming"), std::string::npos);
  const fs::path second = session_other_than(work / "sessions", first);
  ASSERT_FALSE(second.empty());

  const auto t = takes_of(second);
  ASSERT_TRUE(t.is_object());
  ASSERT_EQ(t["folders"].size(), 2u);
  std::map<int, std::string> done_in;  // step -> folder of its done take
  for (const auto& row : t["takes"])
    if (row["status"] == "done") done_in[row["step"]] = row["session"];
  for (int step = 0; step < 6; ++step) EXPECT_TRUE(done_in.count(step)) << "step " << step << "\n" << t.dump(1);
  for (const auto& row : t["takes"]) {
    if (acknowledged.count(row["sequence"])) {
      EXPECT_EQ(row["status"], "done") << row.dump();
      EXPECT_EQ(row["session"], first.string()) << "acknowledged in the first folder, kept there";
    }
    if (row["session"] == first.string() && row["step"] == 3) {
      EXPECT_EQ(row["status"], "interrupted") << "the take the kill cut short";
    }
  }
  // The continuation took over the participant.
  auto reader = pvcap::SessionReader::open(second);
  ASSERT_TRUE(reader) << reader.error().message;
  ASSERT_TRUE(reader.value()->info().participant);
  EXPECT_EQ(reader.value()->info().participant->pseudonym, "T02");
}

namespace {
std::string tmux(const std::string& args) {
  const std::string out = fmt::format("/tmp/pvcap-tmux-out-{}", getpid());
  const auto r = std::system(("tmux -L pvcap-test " + args + " > " + out + " 2>&1").c_str());
  (void)r;
  std::string text = read_all(out);
  std::remove(out.c_str());
  return text;
}

// Waits until the console pane shows `needle` (`times` times).
bool pane_shows(const std::string& needle, std::chrono::seconds timeout, int times = 1) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    const std::string pane = tmux("capture-pane -p -S -500 -t console");
    int n = 0;
    for (auto at = pane.find(needle); at != std::string::npos; at = pane.find(needle, at + 1)) ++n;
    if (n >= times) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}
}  // namespace

// The operator's keyboard in a real terminal (tmux): the participant's details asked first (none
// were given on the command line), then start, pause and resume, skip, redo, abort.
TEST(ProtocolSession, TheOperatorSteersFromTheTerminal) {
  if (std::system("command -v tmux > /dev/null") != 0)
    GTEST_SKIP() << "tmux is not installed (scripts/deps.sh installs it)";
  const fs::path work = work_dir("console");
  const fs::path rig = write_rig(work), protocol = write_protocol(work);
  tmux("kill-server");
  tmux(fmt::format(
      "new-session -d -s console -x 220 -y 60 '{} session --rig {} --root {} --protocol {} --fast "
      "--no-web 2>&1 | tee {}'",
      PVCAP_BIN, rig.string(), (work / "sessions").string(), protocol.string(), (work / "console.log").string()));
  ASSERT_TRUE(pane_shows("Participant code", std::chrono::seconds(20))) << tmux("capture-pane -p -t console");
  tmux("send-keys -t console 'Jane Doe' Enter");  // a name is refused
  ASSERT_TRUE(pane_shows("not accepted", std::chrono::seconds(5))) << tmux("capture-pane -p -t console");
  tmux("send-keys -t console T03 Enter");
  ASSERT_TRUE(pane_shows("Skin tone", std::chrono::seconds(5)));
  tmux("send-keys -t console medium Enter");
  ASSERT_TRUE(pane_shows("Hand order", std::chrono::seconds(5)));
  tmux("send-keys -t console Enter");  // right first
  ASSERT_TRUE(pane_shows("Lighting", std::chrono::seconds(5)));
  tmux("send-keys -t console LCR Enter");
  ASSERT_TRUE(pane_shows("Sensor overlay", std::chrono::seconds(5)));
  tmux("send-keys -t console Enter");
  ASSERT_TRUE(pane_shows("operator: keys:", std::chrono::seconds(60))) << tmux("capture-pane -p -t console");
  tmux("send-keys -t console s");
  ASSERT_TRUE(pane_shows("protocol: recording press_index_finger_low_2x_right", std::chrono::seconds(20)));
  tmux("send-keys -t console p");
  ASSERT_TRUE(pane_shows("operator: paused", std::chrono::seconds(5)));
  tmux("send-keys -t console p");
  ASSERT_TRUE(pane_shows("operator: resumed", std::chrono::seconds(5)));
  ASSERT_TRUE(pane_shows("recording press_index_finger_low_2x_right(2)", std::chrono::seconds(20)));
  tmux("send-keys -t console k");
  ASSERT_TRUE(pane_shows("operator: skipped", std::chrono::seconds(5)));
  // Wait for its end (done, or held by a failed check: the default simulated hand is not steered).
  ASSERT_TRUE(pane_shows("protocol: press_index_finger_high_2x_right d", std::chrono::seconds(20)));
  tmux("send-keys -t console r");
  ASSERT_TRUE(pane_shows("operator: redo press_index_finger_high_2x_right(2)", std::chrono::seconds(5)));
  ASSERT_TRUE(pane_shows("protocol: recording press_index_finger_high_2x_right(2)", std::chrono::seconds(20)));
  tmux("send-keys -t console k");
  ASSERT_TRUE(pane_shows("operator: skipped", std::chrono::seconds(5), 2));
  tmux("send-keys -t console q");
  // pvcap ends, and its pane with it: the end is read from its log.
  ASSERT_TRUE(wait_for_text(work / "console.log", "ended: protocol aborted", std::chrono::seconds(30)))
      << read_all(work / "console.log");
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the takes table follows the report
  tmux("kill-server");

  const auto t = takes_of(only_session(work / "sessions"));
  ASSERT_TRUE(t.is_object());
  std::map<std::string, std::string> status;
  for (const auto& row : t["takes"]) status[row["sequence"]] = row["status"];
  EXPECT_EQ(status["press_index_finger_low_2x_right"], "interrupted") << t.dump(1);
  EXPECT_EQ(status["press_index_finger_low_2x_right(2)"], "skipped");
  EXPECT_EQ(status["press_index_finger_high_2x_right"], "superseded");
  EXPECT_EQ(status["press_index_finger_high_2x_right(2)"], "skipped");
  // What the operator answered is the session's participant and conditions.
  auto reader = pvcap::SessionReader::open(only_session(work / "sessions"));
  ASSERT_TRUE(reader) << reader.error().message;
  const auto& info = reader.value()->info();
  ASSERT_TRUE(info.participant);
  EXPECT_EQ(info.participant->pseudonym, "T03");
  EXPECT_EQ(info.participant->skin_tone, "medium");
  EXPECT_EQ(info.participant->hand_order, "right_first");
  ASSERT_TRUE(info.conditions);
  EXPECT_EQ(info.conditions->lighting, "LCR");
  EXPECT_EQ(info.conditions->sensor_overlay, "unrecorded");
}
