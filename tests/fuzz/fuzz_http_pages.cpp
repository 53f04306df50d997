// libFuzzer target: the session's pages as they run in pvcap (console::WebConsole, its guard and
// every route, a protocol runner behind /command), served in this process on loopback, each input
// sent as one request over a fresh connection. Whatever the bytes, the server answers or closes
// (never a crash, a hang or a leak under ASan); a 500 never carries more than its fixed sentence
// (the details go to the log only); a request without the token is never served a page or a
// command; and the recording behind the pages sees only what a valid request may post.
//
// The pages' own code (web_console.cpp and what it calls) is instrumented; Debian's cpp-httplib is
// a shared library, so its parser runs uninstrumented: crashes in it are still caught, but its
// branches do not guide the fuzzer.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include <spdlog/spdlog.h>

#include "console/page_source.h"
#include "console/web_console.h"
#include "protocol/protocol.h"
#include "protocol/runner.h"

#define PVCAP_STRINGIFY2(x) #x
#define PVCAP_STRINGIFY(x) PVCAP_STRINGIFY2(x)

namespace {

constexpr const char* kToken = "fuzz-token-0123";  // the seeds and the dictionary carry it

// A recording of two cameras and a Sensel, with previews and a pressure frame.
class FakePages : public pvcap::console::PageSource {
 public:
  FakePages() {
    for (const char* name : {"cam0", "cam1"}) {
      pvcap::session::StreamStatus s;
      s.name = name;
      s.kind = "camera";
      s.received = s.good = 100;
      s.since_last_frame_ms = 10;
      status_.streams.push_back(s);
    }
    pvcap::session::StreamStatus sensel;
    sensel.name = "sensel";
    sensel.kind = "sensel";
    sensel.since_last_frame_ms = 5;
    status_.streams.push_back(sensel);
    status_.state = "recording";
    status_.elapsed_s = 12.5;
    preview_ = cv::Mat(48, 64, CV_8UC3, cv::Scalar(40, 90, 160));
    pressure_.grid = pvcap::sensel::kMediumDetail;
    pressure_.counts.assign(std::size_t(pressure_.grid.cells()), 0);
    for (std::size_t i = 0; i < pressure_.counts.size(); i += 97) pressure_.counts[i] = std::uint16_t(i % 4000);
  }
  pvcap::session::RecordingStatus status() const override { return status_; }
  std::size_t camera_count() const override { return 2; }
  std::pair<cv::Mat, std::int64_t> preview(std::size_t camera, bool) const override {
    if (camera >= 2) return {};
    return {preview_, 1'000'000};
  }
  std::optional<pvcap::session::PressureSnapshot> pressure_now() const override { return pressure_; }
  bool post(pvcap::ProtocolEventRecord e) override {
    // Only what the routes post.
    if (e.kind != "fingertip_marked" && e.kind != "prompt_shown" && e.kind != "remote_mark" &&
        e.kind != "remote_stop" && e.kind != "remote_command")
      __builtin_trap();
    posted.fetch_add(1);
    return true;
  }
  void request_stop(std::string) override { stops.fetch_add(1); }
  std::atomic<long> stops{0};
  std::atomic<long> posted{0};

 private:
  pvcap::session::RecordingStatus status_;
  cv::Mat preview_;
  pvcap::session::PressureSnapshot pressure_;
};

class FakeEnv : public pvcap::protocol::RunnerEnv {
 public:
  std::int64_t now_ns() override { return now += 50'000'000; }
  bool commit(const pvcap::ProtocolEventRecord&) override { return true; }
  bool commit_note(const std::string& text) override { return text.size() < 1'000'000; }
  bool devices_live() override { return true; }
  double stream_silence_ms() override { return 10; }
  bool has_pressure() override { return true; }
  std::vector<pvcap::protocol::ForcePoint> pressure(std::int64_t, std::int64_t) override { return {}; }
  std::int64_t now = 1'000'000'000;
};

struct Served {
  FakePages pages;
  FakeEnv env;
  pvcap::protocol::Protocol protocol;
  std::unique_ptr<pvcap::protocol::Runner> runner;
  std::unique_ptr<pvcap::console::WebConsole> web;
  int port = 0;

  Served() {
    spdlog::set_level(spdlog::level::off);  // the handlers log each command: millions of lines
    protocol = pvcap::protocol::load_protocol(PVCAP_STRINGIFY(PVCAP_PROTOCOLS_DIR) "/pressurevision.yaml");
    runner = std::make_unique<pvcap::protocol::Runner>(protocol, "left_first", env, pvcap::protocol::RunnerOptions{});
    auto bound = pvcap::console::WebConsole::bind({.bind = "127.0.0.1", .port = 0, .token = kToken});
    if (!bound) std::abort();
    web = std::move(bound.value());
    port = web->port();
    web->serve(pages, runner.get());
  }
  // Stopped before the process exits: the server threads hold the pages and the runner.
  ~Served() { web->stop(); }
};

Served& served() {
  static Served s;
  return s;
}

// What came back: the whole answer if the server closed (`complete`), else what came within the
// deadline (an event stream never ends by itself; a loaded machine may answer late).
struct Reply {
  std::string text;
  bool complete = false;
};

Reply exchange(int port, const std::uint8_t* data, std::size_t size) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) std::abort();
  // Closed with a reset: millions of connections would otherwise use up the loopback's ports in TIME_WAIT.
  const linger reset{1, 0};
  setsockopt(fd, SOL_SOCKET, SO_LINGER, &reset, sizeof reset);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(std::uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  // libFuzzer's timeout alarm interrupts system calls: an interrupted connect goes on by itself.
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    int error = errno;
    if (error == EINTR) {
      pollfd p{fd, POLLOUT, 0};
      while (poll(&p, 1, 1000) < 0 && errno == EINTR) {
      }
      socklen_t len = sizeof error;
      getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &len);
    }
    if (error != 0) {
      std::fprintf(stderr, "fuzz_http_pages: connect to the pages: %s\n", std::strerror(error));
      std::abort();
    }
  }
  std::size_t sent = 0;
  while (sent < size) {
    const ssize_t n = send(fd, data + sent, size - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the server answered early (a 413) and closed
    sent += std::size_t(n);
  }
  shutdown(fd, SHUT_WR);
  Reply reply;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(400);
  char buf[16384];
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    // Only an orderly close says the answer is whole (a reset may drop what the server had not sent).
    if (n <= 0) {
      reply.complete = n == 0;
      break;
    }
    reply.text.append(buf, std::size_t(n));
    if (reply.text.size() > (8u << 20)) std::abort();  // no page or image of these is this large
    // An event stream's first event is enough: waiting out the deadline would slow every input.
    if (reply.text.find("text/event-stream") != std::string::npos && reply.text.find("\ndata: ") != std::string::npos)
      break;
  }
  close(fd);
  return reply;
}

int status_of(const std::string& reply) {
  if (reply.rfind("HTTP/1.1 ", 0) != 0 || reply.size() < 12) return 0;
  return std::atoi(reply.c_str() + 9);
}

// The token as the server may read it: as sent, or percent-decoded (a query parameter).
bool has_token(const std::string& request) {
  std::string decoded;
  for (std::size_t i = 0; i < request.size(); ++i) {
    if (request[i] == '%' && i + 2 < request.size() && std::isxdigit(static_cast<unsigned char>(request[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(request[i + 2]))) {
      decoded += char(std::stoi(request.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      decoded += request[i];
    }
  }
  return request.find(kToken) != std::string::npos || decoded.find(kToken) != std::string::npos;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Served& s = served();
  const long posted_before = s.pages.posted.load();
  const Reply reply = exchange(s.port, data, size);
  const std::string request(reinterpret_cast<const char*>(data), size);
  const int status = status_of(reply.text);
  // An answer that is not HTTP: a byte that differs from the status line's start, or a whole answer
  // without a status (a cut one may hold only part of the line).
  const std::string head = "HTTP/1.1 ";
  const std::size_t n = std::min(reply.text.size(), head.size());
  if (reply.text.compare(0, n, head, 0, n) != 0 || (reply.complete && !reply.text.empty() && status == 0))
    __builtin_trap();
  // A 500's body is judged only when the answer came whole: the CI once had a 500's status line
  // without its body, most likely the answer cut by the deadline on a loaded machine (httplib writes
  // the head and the body separately).
  if (status == 500 && reply.complete &&
      reply.text.find("the request could not be answered (pvcap's log says why)") == std::string::npos)
    __builtin_trap();
  // Without the token (in the query or the cookie) nothing is served and nothing is posted.
  if (!has_token(request)) {
    if (status >= 200 && status < 300) __builtin_trap();
    if (s.pages.posted.load() != posted_before) __builtin_trap();
  }
  s.runner->tick();
  return 0;
}
