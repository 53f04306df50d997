#include "console/web_console.h"

#include <arpa/inet.h>
#include <sys/socket.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include <fmt/format.h>
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "capture/sensel_units.h"
#include "protocol/runner.h"
#include "console/web_assets.h"
#include "session/recording.h"

namespace pvcap::console {

using protocol::Command;
using protocol::Phase;
using protocol::Runner;
using protocol::RunnerView;

namespace {

constexpr auto kEventInterval = std::chrono::milliseconds(200);  // pushes: the countdown reads smoothly
constexpr double kLiveWindowMs = 250;                             // the recording indicator's window
constexpr double kHeatMapMaxKpa = 60;                             // the heat map's top colour

std::string random_token() {
  std::random_device rd;  // /dev/urandom on Linux
  std::string t;
  for (int i = 0; i < 4; ++i) t += fmt::format("{:08x}", rd());
  return t;
}

// Constant time in the token's length: a wrong token says nothing about how much of it matched.
bool same_token(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d |= static_cast<unsigned char>(a[i] ^ b[i]);
  return d == 0;
}

std::string cookie_value(const std::string& cookies, const std::string& name) {
  std::size_t pos = 0;
  while (pos < cookies.size()) {
    std::size_t end = cookies.find(';', pos);
    if (end == std::string::npos) end = cookies.size();
    std::string part = cookies.substr(pos, end - pos);
    part.erase(0, part.find_first_not_of(' '));
    if (part.rfind(name + "=", 0) == 0) return part.substr(name.size() + 1);
    pos = end + 1;
  }
  return {};
}

nlohmann::json stream_json(const session::StreamStatus& s) {
  return {{"name", s.name},
          {"kind", s.kind},
          {"received", s.received},
          {"good", s.good},
          {"in_video", s.in_video},
          {"incomplete", s.incomplete},
          {"not_received", s.not_received},
          {"queue_overflow", s.queue_overflow},
          {"buffer_underrun", s.buffer_underrun},
          {"encoder_behind", s.encoder_behind},
          {"connection_losses", s.connection_losses},
          {"encoder_backlog", s.encoder_backlog},
          {"spill_backlog", s.spill_backlog},
          {"spilled", s.spilled},
          {"rate_hz", std::round(s.rate_hz * 10) / 10},
          {"since_last_frame_ms", std::round(s.since_last_frame_ms)}};
}

}  // namespace

bool is_loopback_address(const std::string& address) {
  if (address == "localhost" || address == "::1") return true;
  in_addr a{};
  if (inet_pton(AF_INET, address.c_str(), &a) != 1) return false;
  return (ntohl(a.s_addr) >> 24) == 127;
}

WebConsole::WebConsole(WebOptions options) : options_(std::move(options)), server_(std::make_unique<httplib::Server>()) {}

WebConsole::~WebConsole() { stop(); }

Result<std::unique_ptr<WebConsole>> WebConsole::bind(WebOptions options) {
  in_addr a4{};
  in6_addr a6{};
  if (options.bind != "localhost" && inet_pton(AF_INET, options.bind.c_str(), &a4) != 1 &&
      inet_pton(AF_INET6, options.bind.c_str(), &a6) != 1)
    return Error{fmt::format("--web-bind '{}' is not an IP address (e.g. 127.0.0.1, or this machine's address on "
                             "the lab network)",
                             options.bind)};
  if (options.port < 0 || options.port > 65535)
    return Error{fmt::format("--web-port {} is not a port (1-65535, or 0 for any free one)", options.port)};
  if (!is_loopback_address(options.bind) && options.token.empty()) options.token = random_token();
  std::unique_ptr<WebConsole> w(new WebConsole(std::move(options)));
  auto& o = w->options_;
  // Event streams hold a thread each for as long as a page is open: more than the default few.
  w->server_->new_task_queue = [] { return new httplib::ThreadPool(32); };
  w->server_->set_keep_alive_timeout(2);
  // SO_REUSEADDR only: httplib's default adds SO_REUSEPORT, which would let a second session share
  // the first one's port and answer half of its page requests.
  w->server_->set_socket_options([](int sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  if (o.port != 0 && w->server_->bind_to_port(o.bind, o.port)) {
    w->port_ = o.port;
  } else {
    const int requested = o.port;
    w->port_ = w->server_->bind_to_any_port(o.bind);
    if (w->port_ <= 0)
      return Error{fmt::format("the session's pages cannot listen on {} (is it an address of this machine?)", o.bind)};
    if (requested != 0)
      spdlog::warn("port {} on {} is in use: the session's pages are on port {} instead", requested, o.bind, w->port_);
  }
  w->routes();
  return w;
}

std::string WebConsole::url(const std::string& page) const {
  const std::string host = options_.bind.find(':') != std::string::npos ? "[" + options_.bind + "]" : options_.bind;
  std::string u = fmt::format("http://{}:{}/{}", host, port_, page);
  if (!options_.token.empty()) u += "?token=" + options_.token;
  return u;
}

bool WebConsole::authorized(const std::string& query_token, const std::string& cookie) const {
  if (options_.token.empty()) return true;
  return same_token(query_token, options_.token) || same_token(cookie, options_.token);
}

void WebConsole::serve(session::Recording& recording, Runner* runner) {
  recording_ = &recording;
  runner_ = runner;
  thread_ = std::thread([this] {
    if (!server_->listen_after_bind() && !stopping_.load())
      spdlog::error("the session's pages stopped serving (port {}); the recording goes on", port_);
  });
  // stop() can only end a server that is running: wait for it to be (a moment).
  for (int i = 0; i < 200 && !server_->is_running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

void WebConsole::stop() {
  if (stopping_.exchange(true)) return;
  if (thread_.joinable()) {
    // Each open event stream sends its final state and an end (within one push interval).
    for (int i = 0; i < 100 && streams_.load() > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    server_->stop();
    thread_.join();
  }
}

std::string WebConsole::state_json() const {
  nlohmann::json j;
  const auto st = recording_->status();
  const bool live = st.all_live(kLiveWindowMs);
  nlohmann::json streams = nlohmann::json::array();
  for (const auto& s : st.streams) streams.push_back(stream_json(s));
  j["session"] = {{"state", st.state},
                  {"dir", st.session_dir},
                  {"elapsed_s", std::round(st.elapsed_s * 10) / 10},
                  {"samples", st.samples},
                  {"pressure_offset_mean_ms", std::round(st.pressure_offset_mean_ms * 100) / 100},
                  {"pressure_offset_max_ms", std::round(st.pressure_offset_max_ms * 100) / 100},
                  {"free_disk_gb", st.free_disk_bytes < 0 ? -1.0 : std::round(double(st.free_disk_bytes) / 1e8) / 10},
                  {"warnings", st.warnings},
                  {"streams", streams},
                  {"cameras", recording_->rig().cameras.size()},
                  {"devices_live", live}};
  j["pages"] = {{"participant", participant_pages_.load()}, {"operator", operator_pages_.load()}};
  if (auto p = recording_->pressure_now(); p && !p->counts.empty()) {
    const auto sum = sensel::summarize_pressure(p->counts, p->grid);
    j["pressure"] = {{"total_newtons", std::round(sum.total_newtons * 100) / 100},
                     {"contact_mm2", std::round(sum.contact_area_mm2)}};
  }
  if (!runner_) {
    j["protocol"] = false;
    j["recording_indicator"] = st.state == "recording" && live;
    return j.dump();
  }
  const RunnerView v = runner_->view();
  j["protocol"] = true;
  j["phase"] = to_string(v.phase);
  j["paused_in"] = to_string(v.paused_in);
  j["step"] = v.step;
  j["steps"] = v.steps;
  j["takes_done"] = v.takes_done;
  j["sequence"] = v.sequence;
  j["action"] = v.action_name;
  j["text"] = v.action_text;
  j["pictogram"] = v.pictogram.empty() ? "" : fmt::format("/pictogram/{}", v.step);
  j["force"] = v.force;
  j["hand"] = v.hand;
  j["repetition"] = v.repetition;
  j["repetitions"] = v.repetitions;
  j["seconds_left"] = std::round(v.seconds_left * 10) / 10;
  j["waiting_for_devices"] = v.waiting_for_devices;
  j["holding"] = v.holding;
  j["message"] = v.message;
  j["step_status"] = v.step_status;
  // "Recording" is shown only while every device delivers: the participant never performs into a gap.
  j["recording_indicator"] = v.phase == Phase::Recording && live;
  if (v.last) {
    nlohmann::json last = {{"sequence", v.last->sequence}, {"status", v.last->status}};
    if (v.last->check) {
      last["check_ok"] = v.last->check->ok;
      last["problems"] = v.last->check->problems;
      last["mean_newtons"] = std::round(v.last->check->measures.mean_newtons * 100) / 100;
      last["peak_newtons"] = std::round(v.last->check->measures.peak_newtons * 100) / 100;
    }
    j["last"] = last;
  }
  return j.dump();
}

void WebConsole::routes() {
  auto& s = *server_;
  // Every request passes the token check first; the pages keep the token in a cookie so that
  // their images and event stream need not repeat it.
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    // A command must come from the pages themselves: another site open in the operator's browser
    // could otherwise post "abort" to 127.0.0.1 (browsers name a cross-site sender in Origin).
    if (req.method == "POST" && req.has_header("Origin") &&
        req.get_header_value("Origin") != "http://" + req.get_header_value("Host")) {
      res.status = 403;
      res.set_content("commands are taken from this session's own pages only\n", "text/plain; charset=utf-8");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (authorized(req.get_param_value("token"), cookie_value(req.get_header_value("Cookie"), "pvcap_token")))
      return httplib::Server::HandlerResponse::Unhandled;
    res.status = 401;
    res.set_content("This pvcap session's pages need its token: open the address pvcap printed at the start "
                    "(it ends in ?token=...).\n",
                    "text/plain; charset=utf-8");
    return httplib::Server::HandlerResponse::Handled;
  });
  auto page = [this](const char* html) {
    return [this, html](const httplib::Request&, httplib::Response& res) {
      if (!options_.token.empty())
        res.set_header("Set-Cookie", fmt::format("pvcap_token={}; Path=/; SameSite=Strict; HttpOnly", options_.token));
      res.set_header("Cache-Control", "no-store");
      res.set_content(html, "text/html; charset=utf-8");
    };
  };
  s.Get("/", page(web_assets::kIndexHtml));
  s.Get("/participant", page(web_assets::kParticipantHtml));
  s.Get("/operator", page(web_assets::kOperatorHtml));

  s.Get("/state", [this](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(state_json(), "application/json");
  });

  // Server-sent events: the state whenever it changes, and a comment line every few seconds so a
  // vanished page is noticed. Each open page holds one thread; stop() ends them all.
  s.Get("/events", [this](const httplib::Request& req, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");
    auto last = std::make_shared<std::string>();
    auto quiet = std::make_shared<int>(0);
    // Which page listens: the operator sees whether the participant's screen is connected.
    std::atomic<int>& open = req.get_param_value("page") == "participant" ? participant_pages_ : operator_pages_;
    open.fetch_add(1);
    streams_.fetch_add(1);
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, last, quiet](std::size_t, httplib::DataSink& sink) {
          const bool ending = stopping_.load();
          std::string state = state_json();
          std::string out;
          if (state != *last) {
            out = "data: " + state + "\n\n";
            *last = std::move(state);
            *quiet = 0;
          } else if (++*quiet >= 25) {
            out = ": alive\n\n";
            *quiet = 0;
          }
          // At the end the pages get the final state, then word that the session is over.
          if (ending) out += "event: end\ndata: {}\n\n";
          if (!out.empty() && !sink.write(out.data(), out.size())) return false;
          if (ending) {
            sink.done();
            return true;
          }
          std::this_thread::sleep_for(kEventInterval);
          return true;
        },
        [this, &open](bool) {
          open.fetch_sub(1);
          streams_.fetch_sub(1);
        });
  });

  s.Get(R"(/pictogram/(\d+))", [this](const httplib::Request& req, httplib::Response& res) {
    const std::size_t step = std::stoul(req.matches[1]);
    if (!runner_ || step >= runner_->plan().size()) {
      res.status = 404;
      return;
    }
    std::ifstream in(runner_->plan()[step].action->pictogram, std::ios::binary);
    if (!in) {
      res.status = 404;
      return;
    }
    std::ostringstream svg;
    svg << in.rdbuf();
    res.set_header("Cache-Control", "max-age=3600");
    res.set_content(svg.str(), "image/svg+xml");
  });

  // A camera's latest preview: the thumbnail, or (full) the whole frame for marking the fingertip.
  // X-Frame-Ns: when that frame arrived (host clock), which /fingertip sends back.
  auto camera_image = [this](const httplib::Request& req, httplib::Response& res, bool full) {
    if (req.matches[1].length() > 3) {
      res.status = 404;
      return;
    }
    const std::size_t camera = std::stoul(req.matches[1]);
    const auto [image, at] = full ? recording_->preview_full(camera) : recording_->preview(camera);
    std::vector<unsigned char> jpg;
    if (image.empty() || !cv::imencode(".jpg", image, jpg, {cv::IMWRITE_JPEG_QUALITY, full ? 92 : 80})) {
      res.status = 404;
      res.set_content("no image from this camera yet\n", "text/plain");
      return;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Frame-Ns", std::to_string(at));
    res.set_content(std::string(jpg.begin(), jpg.end()), "image/jpeg");
  };
  s.Get(R"(/camera/(\d+)\.jpg)", [camera_image](const httplib::Request& req, httplib::Response& res) {
    camera_image(req, res, false);
  });
  s.Get(R"(/camera/(\d+)/full\.jpg)", [camera_image](const httplib::Request& req, httplib::Response& res) {
    camera_image(req, res, true);
  });

  // The operator marked the fingertip on a camera's frame (for the press check on a real rig):
  // logged on the capture clock with the frame's arrival time, the camera and the pixel.
  s.Post("/fingertip", [this](const httplib::Request& req, httplib::Response& res) {
    auto number = [&](const char* key) -> std::optional<double> {
      const std::string v = req.get_param_value(key);
      if (v.empty() || v.size() > 24) return std::nullopt;
      try {
        std::size_t used = 0;
        const double d = std::stod(v, &used);
        if (used != v.size() || !std::isfinite(d)) return std::nullopt;
        return d;
      } catch (const std::exception&) {
        return std::nullopt;
      }
    };
    const auto camera = number("camera"), x = number("x"), y = number("y"), frame_ns = number("frame_ns");
    const auto cameras = recording_->status().streams;
    std::size_t n_cameras = 0;
    for (const auto& st : cameras) n_cameras += st.kind == "camera";
    if (!camera || !x || !y || !frame_ns || *camera < 0 || *camera >= double(n_cameras) || *camera != std::floor(*camera) ||
        *x < 0 || *y < 0 || *x > 100000 || *y > 100000 || *frame_ns <= 0) {
      res.status = 400;
      res.set_content("expected camera (an index), x, y (pixels) and frame_ns\n", "text/plain");
      return;
    }
    ProtocolEventRecord e;
    e.kind = "fingertip_marked";
    e.detail = nlohmann::json{{"camera", int(*camera)},
                              {"name", cameras[std::size_t(*camera)].name},
                              {"x", *x},
                              {"y", *y},
                              {"frame_ns", std::int64_t(*frame_ns)}}
                   .dump();
    const bool ok = recording_->post(std::move(e));
    spdlog::info("operator page: fingertip marked in {} at ({:.1f}, {:.1f})", cameras[std::size_t(*camera)].name, *x,
                 *y);
    res.status = ok ? 200 : 503;
    res.set_content(ok ? "marked\n" : "not logged: the store did not commit it\n", "text/plain");
  });

  // The latest pressure frame as a heat map: black no pressure, then a perceptual colour map
  // (inferno) up to kHeatMapMaxKpa, on the device's native grid scaled up.
  s.Get("/pressure.png", [this](const httplib::Request&, httplib::Response& res) {
    const auto p = recording_->pressure_now();
    if (!p || p->counts.empty() || int(p->counts.size()) != p->grid.cells()) {
      res.status = 404;
      res.set_content("no pressure frame yet\n", "text/plain");
      return;
    }
    cv::Mat level(p->grid.rows, p->grid.cols, CV_8U);
    for (int r = 0; r < p->grid.rows; ++r)
      for (int c = 0; c < p->grid.cols; ++c) {
        const double kpa = sensel::native_cell_kpa(p->counts[std::size_t(r * p->grid.cols + c)], p->grid);
        level.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(std::clamp(kpa / kHeatMapMaxKpa, 0.0, 1.0) * 255);
      }
    cv::Mat colour;
    cv::applyColorMap(level, colour, cv::COLORMAP_INFERNO);
    colour.setTo(cv::Scalar(0, 0, 0), level == 0);
    cv::resize(colour, colour, {}, 4, 4, cv::INTER_NEAREST);
    std::vector<unsigned char> png;
    cv::imencode(".png", colour, png);
    res.set_header("Cache-Control", "no-store");
    res.set_content(std::string(png.begin(), png.end()), "image/png");
  });

  // The operator's commands, the same as the terminal's keys. Acknowledged only once committed.
  s.Post("/command", [this](const httplib::Request& req, httplib::Response& res) {
    nlohmann::json reply;
    const auto c = protocol::parse_command(req.get_param_value("command"));
    if (!runner_) {
      res.status = 409;
      reply = {{"ok", false}, {"message", "this session runs no protocol"}};
    } else if (!c) {
      res.status = 400;
      reply = {{"ok", false},
               {"message", fmt::format("unknown command '{}'", req.get_param_value("command"))}};
    } else {
      const auto r = runner_->command(*c, req.get_param_value("argument"));
      spdlog::info("operator page: {} -> {}{}", req.get_param_value("command"), r.ok ? "" : "refused: ", r.message);
      reply = {{"ok", r.ok}, {"message", r.message}};
      if (!r.ok) res.status = 409;
    }
    res.set_content(reply.dump(), "application/json");
  });

  // The participant page says when it has put a prompt on the screen: logged on the capture clock.
  s.Post("/shown", [this](const httplib::Request& req, httplib::Response& res) {
    ProtocolEventRecord e;
    e.kind = "prompt_shown";
    const std::string step = req.get_param_value("step");
    if (!step.empty() && step.find_first_not_of("0123456789") == std::string::npos && step.size() < 9)
      e.step = std::stoll(step);
    e.detail = nlohmann::json{{"sequence", req.get_param_value("sequence")},
                              {"phase", req.get_param_value("phase")},
                              {"screen", req.get_param_value("screen")}}
                   .dump();
    spdlog::debug("participant page {} shows {} ({})", req.get_param_value("screen"), req.get_param_value("sequence"),
                  req.get_param_value("phase"));
    const bool ok = recording_->post(std::move(e));
    res.status = ok ? 200 : 503;
    res.set_content(ok ? "logged\n" : "not logged: the store did not commit it\n", "text/plain");
  });

  s.set_exception_handler([](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    spdlog::warn("the session's pages: {} {}: {}", req.method, req.path, what);
    res.status = 500;
    res.set_content(what + "\n", "text/plain");
  });
}

}  // namespace pvcap::console
