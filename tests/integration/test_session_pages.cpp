// The session's pages in a real browser: Debian's headless Chromium loads the
// participant display and the operator console of a running `pvcap session`
// (the simulated rig's cameras in their private network namespace, the pages in
// the machine's own) and the DOM follows the runner through the takes; the
// operator's commands over HTTP; and off loopback, nothing without the token.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <regex>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "calib/camera_model.h"
#include "calib/rig_calibration.h"
#include "headless_browser.h"
#include "session_under_test.h"
#include "sim/fingertip.h"
#include "sim/truth.h"
#include "storage/index/session_reader.h"

namespace fs = std::filesystem;
using namespace pvcap::testing;

namespace {

// Two force levels of one press with each hand: four takes of ~4 s.
fs::path write_protocol(const fs::path& dir) { return write_press_protocol(dir, "[low, high]", 1.0, 1.0, 2.0, 0.5); }
fs::path write_rig(const fs::path& dir) { return write_protocol_rig(dir); }

// The address pvcap printed for a page, e.g. "operator console:    http://127.0.0.1:41234/operator".
std::string printed_url(const fs::path& log, const std::string& label) {
  const std::regex re(label + R"(:\s+(http://\S+))");
  std::smatch m;
  const std::string text = read_all(log);
  return std::regex_search(text, m, re) ? m[1].str() : std::string();
}

std::vector<std::string> all(const std::string& text, const std::string& pattern) {
  std::vector<std::string> out;
  const std::regex re(pattern);
  for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator(); ++it)
    out.push_back((*it)[1].str());
  return out;
}

struct Url {
  std::string host;
  int port = 0;
  std::string token;
};
Url parse(const std::string& url) {
  std::smatch m;
  const std::regex re(R"(http://([^:/]+):(\d+)/\w*(?:\?token=(\w+))?)");
  if (!std::regex_match(url, m, re)) return {};
  return {m[1], std::stoi(m[2]), m[3]};
}

const fs::path kScreenshots = fs::path(PVCAP_BINARY_DIR) / "tests" / "screenshots";

// A raw connection to 127.0.0.1:port, for requests no well-behaved client sends.
int connect_loopback(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(std::uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// What arrives on `fd` within `timeout_ms` (up to the first 4 KiB).
std::string read_some(int fd, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  if (poll(&p, 1, timeout_ms) <= 0) return {};
  char buf[4096];
  const ssize_t n = recv(fd, buf, sizeof buf, 0);
  return n > 0 ? std::string(buf, std::size_t(n)) : std::string();
}

std::int64_t rss_kib(pid_t pid) {
  std::ifstream in(fmt::format("/proc/{}/status", pid));
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stoll(line.substr(6));
  return -1;
}

// Stops the recorder however the test ends.
struct StopOnExit {
  pid_t pid;
  ~StopOnExit() {
    if (pid <= 0) return;
    kill(pid, SIGINT);
    waitpid(pid, nullptr, 0);
  }
};

}  // namespace

TEST(SessionPages, TheParticipantAndOperatorPagesFollowTheRunnerThroughTheTakes) {
  HeadlessBrowser browser(1920, 1080);
  if (!browser.ok()) GTEST_SKIP() << "chromium is not installed (scripts/deps.sh installs it)";
  const fs::path work = work_dir("pages");
  const pid_t pid =
      spawn_pvcap(fmt::format("session --rig {} --root {} --protocol {} --auto --fast --participant T05 "
                              "--web-port 0",
                              write_rig(work).string(), (work / "sessions").string(), write_protocol(work).string()),
                  work / "pvcap.log");
  ASSERT_TRUE(wait_for_text(work / "pvcap.log", "operator console:", std::chrono::seconds(60)))
      << read_all(work / "pvcap.log");
  const std::string participant_url = printed_url(work / "pvcap.log", "participant display");
  const std::string operator_url = printed_url(work / "pvcap.log", "operator console");
  ASSERT_EQ(parse(participant_url).host, "127.0.0.1") << "loopback by default: " << participant_url;
  EXPECT_EQ(parse(participant_url).token.size(), 32u) << "a token on loopback too: " << participant_url;
  const std::string participant = browser.open(participant_url);
  const std::string operator_page = browser.open(operator_url);
  ASSERT_FALSE(participant.empty());
  ASSERT_FALSE(operator_page.empty());

  const Url u = parse(operator_url);
  httplib::Client client(u.host, u.port);
  client.set_default_headers({{"Cookie", "pvcap_token=" + u.token}});  // as the pages' own requests carry it
  auto state = [&] {
    auto st = client.Get("/state");
    return st ? nlohmann::json::parse(st->body) : nlohmann::json::object();
  };
  auto text = [&](const std::string& tab, const std::string& id) {
    const auto v = browser.eval(tab, "document.getElementById('" + id + "').textContent");
    return v.is_string() ? v.get<std::string>() : std::string();
  };
  // Once both pages listen, pause the take being recorded.
  for (int i = 0; i < 400; ++i) {
    const auto st = state();
    if (st.contains("pages") && st["pages"]["participant"] == 1 && st["pages"]["operator"] == 1 &&
        st["phase"] == "recording")
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const std::string paused_take = state().value("sequence", "");
  auto r = client.Post("/command", "command=pause", "application/x-www-form-urlencoded");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(state()["phase"], "paused");
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  EXPECT_EQ(text(participant, "status"), "Paused");
  EXPECT_EQ(text(operator_page, "phase").rfind("paused (", 0), 0u) << text(operator_page, "phase");
  r = client.Post("/command", "command=resume", "application/x-www-form-urlencoded");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
  std::this_thread::sleep_for(std::chrono::milliseconds(600));  // the operator's log shows it
  // Another site open in the operator's browser cannot steer the session.
  r = client.Post("/command", httplib::Headers{{"Origin", "http://example.org"}}, "command=abort",
                  "application/x-www-form-urlencoded");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  r = client.Post("/command", "command=fly", "application/x-www-form-urlencoded");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(r->body.find("unknown command 'fly'"), std::string::npos);
  r = client.Post("/command", "command=note&argument=participant+asked+for+water", "application/x-www-form-urlencoded");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;

  // Until the session ends: what the participant's page shows, sampled; a screenshot of each phase.
  std::set<std::string> phases_seen;
  bool indicator_seen = false, countdown_digit_seen = false;
  int exit_status = 0;
  while (waitpid(pid, &exit_status, WNOHANG) == 0) {
    const auto look = browser.eval(participant,
                                   "({phase: document.body.dataset.phase, "
                                   "indicator: document.getElementById('indicator').classList.contains('on'), "
                                   "big: document.getElementById('big').hidden ? '' : "
                                   "document.getElementById('big').textContent})");
    if (look.is_object()) {
      const std::string phase = look.value("phase", "");
      if (!phases_seen.count(phase) && (phase == "recording" || phase == "countdown" || phase == "prompt"))
        browser.screenshot(participant, kScreenshots / ("participant-" + phase + ".png"));
      phases_seen.insert(phase);
      indicator_seen = indicator_seen || look.value("indicator", false);
      const std::string big = look.value("big", "");
      countdown_digit_seen = countdown_digit_seen || (big.size() == 1 && std::isdigit(big[0]));
    }
    if (!fs::exists(kScreenshots / "operator.png") && phases_seen.count("rest"))
      browser.screenshot(operator_page, kScreenshots / "operator.png");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0) << read_all(work / "pvcap.log");
  const auto page_errors = browser.errors();  // before the server went away
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::string participant_dom = browser.dom(participant);
  const std::string operator_dom = browser.dom(operator_page);
  browser.screenshot(participant, kScreenshots / "participant-done.png");
  EXPECT_TRUE(page_errors.empty()) << fmt::format("{}", fmt::join(page_errors, "\n"));
  for (const char* phase : {"prompt", "countdown", "recording", "rest", "done"})
    EXPECT_TRUE(phases_seen.count(phase)) << phase << " never shown";
  EXPECT_TRUE(indicator_seen) << "the recording indicator never showed";
  EXPECT_TRUE(countdown_digit_seen) << "no countdown digit";
  for (const char* png :
       {"participant-prompt.png", "participant-countdown.png", "participant-recording.png", "operator.png"})
    EXPECT_TRUE(fs::exists(kScreenshots / png)) << png;

  // The participant page put up each prompt as the runner reached it, in plan order, pushed (one
  // load, no reloads), and ended on the thanks. The take paused while recording was retaken: (2).
  const auto shown = all(participant_dom, R"(<li data-phase="\w+">([^<]+)</li>)");
  std::vector<std::string> expected;
  for (const std::string take : {"press_index_finger_low_2x_right", "press_index_finger_high_2x_right",
                                 "press_index_finger_low_2x_left", "press_index_finger_high_2x_left"}) {
    expected.push_back(take);
    if (take == paused_take) expected.push_back(take + "(2)");
  }
  ASSERT_GE(shown.size(), 3u) << participant_dom;
  const auto from = std::find(expected.begin(), expected.end(), shown[0]);
  EXPECT_EQ(shown, std::vector<std::string>(from, expected.end())) << "paused: " << paused_take;
  EXPECT_NE(std::find(shown.begin(), shown.end(), paused_take + "(2)"), shown.end()) << paused_take;
  EXPECT_NE(participant_dom.find("Thank you! The session is complete."), std::string::npos) << participant_dom;
  EXPECT_NE(participant_dom.find("Press with your index finger"), std::string::npos) << participant_dom;
  EXPECT_NE(participant_dom.find("src=\"/pictogram/"), std::string::npos) << "the pictogram was shown";

  // The operator page: every take done, what happened in order, the live views loaded.
  const auto marks = all(operator_dom, R"(<span class="(\w+)(?: current)?" title="take)");
  EXPECT_EQ(marks, std::vector<std::string>(4, "done")) << operator_dom;
  const auto log = all(operator_dom, R"(<li>[^<]*?  ([^<]+)</li>)");
  const auto at = [&](const std::string& m) { return std::find(log.begin(), log.end(), m) - log.begin(); };
  const std::string log_text = fmt::format("{}", fmt::join(log, " / "));
  EXPECT_LT(at("the protocol is complete"), at("resumed")) << "newest first: " << log_text;
  EXPECT_LT(at("resumed"), at("paused")) << log_text;
  EXPECT_LT(at("press_index_finger_high_2x_left done"), at("press_index_finger_low_2x_left done")) << log_text;
  EXPECT_LT(at("paused"), std::ptrdiff_t(log.size())) << log_text;
  int thumbnails = 0, heat_maps = 0;
  for (const auto& tag : all(operator_dom, R"((<img[^>]*>))")) {
    if (tag.find("data-loaded=\"1\"") == std::string::npos) continue;
    thumbnails += tag.find("alt=\"camera ") != std::string::npos;
    heat_maps += tag.find("id=\"heat\"") != std::string::npos;
  }
  EXPECT_EQ(thumbnails, 4) << "every camera's thumbnail loaded: " << operator_dom;
  EXPECT_EQ(heat_maps, 1) << "the pressure heat map loaded";
  EXPECT_NE(operator_dom.find("<td>cam0</td>"), std::string::npos) << "drop counters per stream";
  EXPECT_NE(operator_dom.find("camera to pressure offset"), std::string::npos);
  EXPECT_NE(operator_dom.find("participant screen on"), std::string::npos);

  // In the store: each prompt the page displayed, on the capture clock, and the operator's pause and note.
  fs::path session;
  for (const auto& e : fs::directory_iterator(work / "sessions"))
    if (e.is_directory()) session = e.path();
  auto reader = pvcap::SessionReader::open(session);
  ASSERT_TRUE(reader) << reader.error().message;
  std::set<std::string> logged;
  bool paused = false;
  const auto events = reader.value()->protocol_events();
  ASSERT_TRUE(events);
  for (const auto& e : events.value()) {
    if (e.kind == "prompt_shown") {
      logged.insert(nlohmann::json::parse(e.detail)["sequence"].get<std::string>());
      EXPECT_GT(e.host_ns, 0);
    }
    paused = paused || e.kind == "pause";
  }
  for (const auto& s : shown)
    EXPECT_TRUE(logged.count(s)) << s << " was displayed but its display is not logged: "
                                 << fmt::format("{}", fmt::join(logged, " / "));
  EXPECT_TRUE(paused);
  bool noted = false;
  const auto notes = reader.value()->operator_notes();
  ASSERT_TRUE(notes);
  for (const auto& n : notes.value()) noted = noted || n.text == "participant asked for water";
  EXPECT_TRUE(noted);
}

// Off loopback the pages need the session's token: generated and printed when not given. The
// non-loopback address lives in a network namespace the test makes (no traffic leaves the machine).
TEST(SessionPages, OffLoopbackEveryRequestNeedsTheToken) {
  const fs::path work = work_dir("pages-token");
  const std::string ns = fmt::format("pvcap-test-{}", getpid());
  ASSERT_EQ(std::system(fmt::format("ip netns add {0} && ip -n {0} link set lo up && "
                                    "ip -n {0} addr add 10.231.0.1/32 dev lo",
                                    ns)
                            .c_str()),
            0);
  const pid_t pid = spawn_pvcap(fmt::format("session --rig {} --root {} --duration 30 --web-bind 10.231.0.1 "
                                            "--web-port 0",
                                            write_rig(work).string(), (work / "sessions").string()),
                                work / "pvcap.log", "ip netns exec " + ns);
  const bool started = wait_for_text(work / "pvcap.log", "operator console:", std::chrono::seconds(60));
  const Url u = parse(printed_url(work / "pvcap.log", "operator console"));
  std::vector<int> codes;
  std::string refusal;
  std::thread client_thread([&] {
    // This thread only joins the test's namespace: it reaches 10.231.0.1 as a lab machine would.
    const int fd = open(fmt::format("/run/netns/{}", ns).c_str(), O_RDONLY);
    if (fd < 0 || setns(fd, CLONE_NEWNET) != 0) return;
    close(fd);
    httplib::Client c(u.host, u.port);
    for (const std::string& path : std::vector<std::string>{"/operator", "/participant", "/state", "/camera/0.jpg",
                                                            "/operator?token=0000000000000000",
                                                            "/operator?token=" + u.token, "/state?token=" + u.token}) {
      auto r = c.Get(path);
      codes.push_back(r ? r->status : -1);
      if (r && r->status == 401 && refusal.empty()) refusal = r->body;
    }
    auto r = c.Post("/command", "command=abort", "application/x-www-form-urlencoded");
    codes.push_back(r ? r->status : -1);
  });
  client_thread.join();
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  std::system(fmt::format("ip netns delete {}", ns).c_str());
  ASSERT_TRUE(started) << read_all(work / "pvcap.log");
  EXPECT_EQ(u.host, "10.231.0.1");
  EXPECT_EQ(u.token.size(), 32u) << "a generated token, printed with the address";
  EXPECT_EQ(codes, (std::vector<int>{401, 401, 401, 401, 401, 200, 200, 401})) << read_all(work / "pvcap.log");
  EXPECT_NE(refusal.find("token"), std::string::npos) << refusal;
}

// A real rig's press check needs the fingertip marked by hand: on the operator page a click on a
// camera's view opens its whole frame, and a click on the fingertip there is logged with the frame's
// time; `pvcap calibrate check` then compares it with the pressure of that instant.
TEST(SessionPages, TheOperatorMarksTheFingertipForThePressCheck) {
  HeadlessBrowser browser(1600, 1000);
  if (!browser.ok()) GTEST_SKIP() << "chromium is not installed (scripts/deps.sh installs it)";
  const fs::path work = work_dir("mark");
  const fs::path rig = work / "rig.yaml";
  std::ofstream(rig) << sim_rig_yaml({{}, {}}, 640, 480, 30, 15, "free-run", /*sensel=*/true);
  const pid_t pid = spawn_pvcap(
      fmt::format("session --rig {} --root {} --duration 14 --web-port 0", rig.string(), (work / "sessions").string()),
      work / "pvcap.log");
  ASSERT_TRUE(wait_for_text(work / "pvcap.log", "operator console:", std::chrono::seconds(60)))
      << read_all(work / "pvcap.log");
  const std::string tab = browser.open(printed_url(work / "pvcap.log", "operator console"));
  ASSERT_FALSE(tab.empty());

  // The simulator's truth (written while it runs): where camera 1 images the press point (100, 60).
  std::optional<pvcap::sim::RigTruth> truth;
  for (int i = 0; i < 200 && !truth; ++i) {
    for (const auto& e : fs::directory_iterator(work / "sessions"))
      if (e.path().filename().string().rfind(".sim-truth-", 0) == 0 && fs::exists(e.path() / "rig.json"))
        if (auto t = pvcap::sim::read_rig_truth(e.path())) truth = t.value();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(truth);
  const auto model = truth->cameras[1].model;
  const cv::Point2d tip = model.project({100.0, 60.0, 0.0});

  // Open camera 1's frame by clicking its thumbnail, until the frozen frame shows a press.
  bool marked = false;
  for (int attempt = 0; attempt < 40 && !marked; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    browser.eval(tab, "(() => { const i = document.querySelectorAll('#cams img')[1]; if (i) i.click(); })()");
    nlohmann::json ready;
    for (int i = 0; i < 40; ++i) {
      ready = browser.eval(tab,
                           "(() => { const f = document.getElementById('mark-frame'); return marking && "
                           "f.complete && f.naturalWidth > 0 && f.style.width ? [f.naturalWidth, "
                           "Number(marking.frameNs)] : null; })()");
      if (ready.is_array()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (!ready.is_array()) continue;
    EXPECT_EQ(ready[0].get<int>(), 640) << "the whole frame, not the thumbnail";
    const auto frame_ns = ready[1].get<std::int64_t>();
    if (pvcap::sim::fingertip_force(frame_ns - 5'000'000, 1.0) < 0.6) {  // not pressing then: look again
      browser.eval(tab, "closeMark()");
      continue;
    }
    browser.eval(tab, fmt::format("(() => {{ const f = document.getElementById('mark-frame'); const b = "
                                  "f.getBoundingClientRect(); f.dispatchEvent(new MouseEvent('click', {{bubbles: true, "
                                  "clientX: Math.round(b.left + ({} + 0.5) * b.width / f.naturalWidth), clientY: "
                                  "Math.round(b.top + ({} + 0.5) * b.height / f.naturalHeight)}})); }})()",
                                  tip.x, tip.y));
    for (int i = 0; i < 40 && !marked; ++i) {
      marked = browser.eval(tab, "document.getElementById('mark-reply').textContent")
                   .get<std::string>()
                   .rfind("marked at", 0) == 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    fs::create_directories(kScreenshots);
    browser.screenshot(tab, kScreenshots / "operator-mark-fingertip.png");
  }
  ASSERT_TRUE(marked) << "no frame showed a press in 40 tries";
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_all(work / "pvcap.log");

  fs::path session;
  for (const auto& e : fs::directory_iterator(work / "sessions"))
    if (e.is_directory() && e.path().filename().string()[0] != '.') session = e.path();
  auto reader = pvcap::SessionReader::open(session);
  ASSERT_TRUE(reader);
  const auto events = reader.value()->protocol_events().value();
  const auto mark =
      std::find_if(events.begin(), events.end(), [](const auto& e) { return e.kind == "fingertip_marked"; });
  ASSERT_NE(mark, events.end());
  const auto d = nlohmann::json::parse(mark->detail);
  EXPECT_EQ(d["camera"], 1);
  EXPECT_EQ(d["name"], "cam1");
  // Clicks are whole CSS pixels; the frame is enlarged about 1.7 times in this window.
  EXPECT_NEAR(d["x"].get<double>(), tip.x, 0.4) << "the click lands on the frame's own pixel";
  EXPECT_NEAR(d["y"].get<double>(), tip.y, 0.4);

  // The press check with the true calibration: the marked press agrees with the pressure to within
  // the click's own precision (a CSS pixel of the enlarged frame, about 0.6 image px; at 640 x 480 an
  // image pixel is 1.1 mm on the pad), and the automatic check of the same presses within 1 mm.
  pvcap::calib::RigCalibration cal;
  for (const auto& c : truth->cameras) {
    pvcap::calib::CameraCalibration cc;
    cc.name = c.name;
    cc.model = c.model;
    cc.intrinsics = cc.pad = pvcap::calib::MeasuredBy{"truth", "", 0, 0.0};
    cc.cells_to_ideal = pvcap::calib::cells_to_ideal(cc.model, cal.pad);
    cc.pad_corners_px = pvcap::calib::pad_corners_px(cc.model, cal.pad);
    cal.cameras.push_back(cc);
  }
  ASSERT_TRUE(pvcap::calib::save_rig_calibration(work / "truth.calibration.yaml", cal).ok());
  const auto check = run_pvcap(
      fmt::format("calibrate check {} --calibration {}", session.string(), (work / "truth.calibration.yaml").string()));
  EXPECT_EQ(check.exit_code, 0) << check.output;
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(check.output, m, std::regex(R"(cam1: 1 marked presses; .* median [\d.]+ px / ([\d.]+) mm)")))
      << check.output;
  EXPECT_LE(std::stod(m[1]), 2.0) << check.output;
  ASSERT_TRUE(std::regex_search(check.output, m, std::regex(R"(cam1: \d+ presses; .* max [\d.]+ px / ([\d.]+) mm)")))
      << check.output;
  EXPECT_LE(std::stod(m[1]), 1.0) << check.output;
  EXPECT_TRUE(browser.errors().empty()) << fmt::format("{}", fmt::join(browser.errors(), "\n"));
}

// Every route of the running pages, probed as another local user or a hostile page would: nothing
// without the token on loopback either, nothing for a foreign Host (DNS rebinding), a 100 MB POST
// refused before it is read, and 40 event streams cannot keep the participant's page from being
// served.
TEST(SessionPages, EveryRouteIsGuardedAndRequestsAreBounded) {
  const fs::path work = work_dir("pages-guard");
  const pid_t pid = spawn_pvcap(fmt::format("session --rig {} --root {} --duration 90 --web-port 0",
                                            write_rig(work).string(), (work / "sessions").string()),
                                work / "pvcap.log");
  StopOnExit stop{pid};
  ASSERT_TRUE(wait_for_text(work / "pvcap.log", "operator console:", std::chrono::seconds(60)))
      << read_all(work / "pvcap.log");
  const Url u = parse(printed_url(work / "pvcap.log", "operator console"));
  ASSERT_EQ(u.host, "127.0.0.1");
  ASSERT_EQ(u.token.size(), 32u) << "a token on loopback too";
  const std::string token = "token=" + u.token;
  httplib::Client c(u.host, u.port);

  // Without the token, every route: 401.
  for (const char* path : {"/", "/participant", "/operator", "/state", "/events", "/camera/0.jpg", "/camera/0/full.jpg",
                           "/pressure.png", "/pictogram/0", "/no-such-page"}) {
    auto r = c.Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 401) << path;
  }
  for (const char* path : {"/command", "/fingertip", "/shown"}) {
    auto r = c.Post(path, "command=abort", "application/x-www-form-urlencoded");
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 401) << path;
  }
  // With it: the pages, and once the page set its cookie, the cookie alone.
  auto page = c.Get("/operator?" + token);
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  const std::string cookie = page->get_header_value("Set-Cookie");
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos) << cookie;
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos) << cookie;
  auto by_cookie = c.Get("/state", httplib::Headers{{"Cookie", "pvcap_token=" + u.token}});
  ASSERT_TRUE(by_cookie);
  EXPECT_EQ(by_cookie->status, 200);
  // A foreign Host (a rebinding page names itself), even with the token: 403.
  for (const std::string& host :
       std::vector<std::string>{"rebind.example", "rebind.example:" + std::to_string(u.port), "127.0.0.1.nip.io"}) {
    auto r = c.Get("/state?" + token, httplib::Headers{{"Host", host}});
    ASSERT_TRUE(r) << host;
    EXPECT_EQ(r->status, 403) << host;
  }
  auto local = c.Get("/state?" + token, httplib::Headers{{"Host", fmt::format("localhost:{}", u.port)}});
  ASSERT_TRUE(local);
  EXPECT_EQ(local->status, 200) << "localhost is this machine";
  // A command from another site's page (its Origin is not the pages' own): 403.
  auto cross = c.Post("/command?" + token, httplib::Headers{{"Origin", "http://example.org"}}, "command=abort",
                      "application/x-www-form-urlencoded");
  ASSERT_TRUE(cross);
  EXPECT_EQ(cross->status, 403);
  // A malformed index in a path: answered (404), never an error page with internals.
  auto huge_index = c.Get("/pictogram/99999999999999999999999?" + token);
  ASSERT_TRUE(huge_index);
  EXPECT_EQ(huge_index->status, 404);
  // A command, note or shown prompt that is not UTF-8 text (no page sends one): refused (400), never
  // stored (the session's events would no longer be writable as JSON) and never an error page.
  for (const char* body : {"command=pa%FF%FFus", "command=note&argument=%ED%A0%80", "command=note&argument=%C0%AF"}) {
    auto r = c.Post("/command?" + token, body, "application/x-www-form-urlencoded");
    ASSERT_TRUE(r) << body;
    EXPECT_EQ(r->status, 400) << body << ": " << r->body;
    EXPECT_NE(r->body.find("a command is UTF-8 text"), std::string::npos) << r->body;
  }
  auto shown = c.Post("/shown?" + token, "step=1&sequence=%FF&phase=prompt&screen=participant",
                      "application/x-www-form-urlencoded");
  ASSERT_TRUE(shown);
  EXPECT_EQ(shown->status, 400) << shown->body;
  auto note =
      c.Post("/command?" + token, "command=note&argument=caf%C3%A9+%F0%9F%91%8D", "application/x-www-form-urlencoded");
  ASSERT_TRUE(note);
  EXPECT_NE(note->status, 400) << "well-formed UTF-8 (an accent, an emoji) is text: " << note->body;

  // A 100 MB POST: refused on its headers (413), the recorder's memory unchanged.
  const std::int64_t rss_before = rss_kib(pid);
  {
    const int fd = connect_loopback(u.port);
    ASSERT_GE(fd, 0);
    const std::string head = fmt::format(
        "POST /command?{} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: application/x-www-form-urlencoded\r\n"
        "Content-Length: 104857600\r\n\r\n",
        token, u.port);
    ASSERT_EQ(send(fd, head.data(), head.size(), MSG_NOSIGNAL), ssize_t(head.size()));
    const std::string answer = read_some(fd, 5000);
    EXPECT_EQ(answer.rfind("HTTP/1.1 413", 0), 0u) << answer;
    const std::string chunk(64 * 1024, 'x');  // the body anyway, as a flood would: it is not kept
    for (int i = 0; i < 1600 && send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL) > 0; ++i) {
    }
    close(fd);
  }
  const std::int64_t rss_after = rss_kib(pid);
  std::printf("recorder's resident memory: %lld KiB before the 100 MB POST, %lld KiB after\n", (long long)rss_before,
              (long long)rss_after);
  EXPECT_LT(rss_after - rss_before, 20 * 1024) << "the body was not buffered";

  // 40 event streams: 12 are served, the others told to close a page; the participant's page and
  // its own stream are still served.
  std::vector<int> streams;
  int served = 0, refused = 0;
  for (int i = 0; i < 40; ++i) {
    const int fd = connect_loopback(u.port);
    ASSERT_GE(fd, 0);
    const std::string get = fmt::format("GET /events?{} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n", token, u.port);
    send(fd, get.data(), get.size(), MSG_NOSIGNAL);
    const std::string answer = read_some(fd, 3000);
    served += answer.rfind("HTTP/1.1 200", 0) == 0;
    refused += answer.rfind("HTTP/1.1 503", 0) == 0;
    streams.push_back(fd);
  }
  EXPECT_EQ(served, 12);
  EXPECT_EQ(refused, 28);
  const auto t0 = std::chrono::steady_clock::now();
  auto participant = c.Get("/participant?" + token);
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(participant);
  EXPECT_EQ(participant->status, 200);
  EXPECT_LT(took_s, 2.0) << "the participant's page waited for a thread";
  {
    const int fd = connect_loopback(u.port);
    const std::string get =
        fmt::format("GET /events?page=participant&{} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n", token, u.port);
    send(fd, get.data(), get.size(), MSG_NOSIGNAL);
    EXPECT_EQ(read_some(fd, 3000).rfind("HTTP/1.1 200", 0), 0u) << "the participant's own stream";
    close(fd);
  }
  for (const int fd : streams) close(fd);
  stop.pid = -1;
  kill(pid, SIGINT);
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << read_all(work / "pvcap.log");
}

// The token from a file (not the command line, where `ps` shows it), and --no-web-token, which is
// for loopback only.
TEST(SessionPages, TheTokenComesFromAFileAndNoTokenIsForLoopbackOnly) {
  const fs::path work = work_dir("pages-token-file");
  const fs::path rig = write_rig(work);
  std::ofstream(work / "token") << "lab-token-2026_abc\n";
  const auto with_file =
      run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --web-port 0 --web-token-file {}", rig.string(),
                            (work / "a").string(), (work / "token").string()));
  EXPECT_EQ(with_file.exit_code, 0) << with_file.output;
  EXPECT_NE(with_file.output.find("/operator?token=lab-token-2026_abc"), std::string::npos) << with_file.output;

  const auto off_loopback =
      run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --web-bind 10.231.0.1 --no-web-token",
                            rig.string(), (work / "b").string()));
  EXPECT_EQ(off_loopback.exit_code, 2) << off_loopback.output;
  EXPECT_NE(off_loopback.output.find("--no-web-token is for loopback only"), std::string::npos) << off_loopback.output;
  EXPECT_FALSE(fs::exists(work / "b")) << "refused before anything was recorded";

  const auto none = run_pvcap(fmt::format("session --rig {} --root {} --duration 2 --web-port 0 --no-web-token",
                                          rig.string(), (work / "c").string()));
  EXPECT_EQ(none.exit_code, 0) << none.output;
  EXPECT_EQ(none.output.find("?token="), std::string::npos) << none.output;
}
