#include "console/web_console.h"
#include "console/web_request.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <fmt/format.h>
#include <httplib.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "codec/sensel_units.h"
#include "console/web_assets.h"
#include "console/web_images.h"
#include "console/web_status.h"
#include "protocol/runner.h"

namespace pvcap::console {

using protocol::Command;
using protocol::Phase;
using protocol::Runner;
using protocol::RunnerView;

namespace {

constexpr auto kEventInterval = std::chrono::milliseconds(200);  // pushes: the countdown reads smoothly

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

// Whether text is well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing past U+10FFFF).
// A page sends nothing else; other bytes would be stored in the session's events and make its JSON unwritable.
bool well_formed_utf8(const std::string& text) {
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = s[i];
    std::size_t length = 0;
    unsigned char low = 0x80, high = 0xBF;  // the bounds of the second byte
    if (c < 0x80) {
      ++i;
      continue;
    } else if (c >= 0xC2 && c <= 0xDF) {
      length = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      length = 3;
      if (c == 0xE0) low = 0xA0;   // overlong
      if (c == 0xED) high = 0x9F;  // surrogates
    } else if (c >= 0xF0 && c <= 0xF4) {
      length = 4;
      if (c == 0xF0) low = 0x90;   // overlong
      if (c == 0xF4) high = 0x8F;  // past U+10FFFF
    } else {
      return false;
    }
    if (i + length > n || s[i + 1] < low || s[i + 1] > high) return false;
    for (std::size_t k = 2; k < length; ++k)
      if (s[i + k] < 0x80 || s[i + k] > 0xBF) return false;
    i += length;
  }
  return true;
}

// A number in a route's path (\d+ matched); one too long to be an index is no index (a 404).
std::size_t index_in_path(const std::string& digits) {
  return digits.size() > 6 ? SIZE_MAX : std::size_t(std::stoul(digits));
}

// The names a request to these pages may give as its Host: the bound address, the loopback names,
// this machine's name, and for a wildcard bind every address of its interfaces. A page of another
// site that rebinds its own name to this machine gives its own name, and is refused.
std::vector<std::string> local_host_names(const std::string& bind) {
  std::vector<std::string> names = {bind, "localhost", "127.0.0.1", "::1"};
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) == 0 && name[0]) {
    std::string n = name;
    for (char& c : n) c = char(std::tolower(static_cast<unsigned char>(c)));
    names.push_back(n);
    names.push_back(n + ".local");
  }
  if (bind == "0.0.0.0" || bind == "::") {
    ifaddrs* list = nullptr;
    if (getifaddrs(&list) == 0) {
      for (ifaddrs* i = list; i; i = i->ifa_next) {
        if (!i->ifa_addr) continue;
        char text[INET6_ADDRSTRLEN] = {};
        const int family = i->ifa_addr->sa_family;
        if (family == AF_INET)
          inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(i->ifa_addr)->sin_addr, text, sizeof text);
        else if (family == AF_INET6)
          inet_ntop(AF_INET6, &reinterpret_cast<sockaddr_in6*>(i->ifa_addr)->sin6_addr, text, sizeof text);
        if (text[0]) names.emplace_back(text);
      }
      freeifaddrs(list);
    }
  }
  return names;
}

}  // namespace

bool parameters_are_text(const httplib::Request& req) {
  return std::all_of(req.params.begin(), req.params.end(),
                     [](const auto& p) { return well_formed_utf8(p.first) && well_formed_utf8(p.second); });
}

WebOptions with_token(WebOptions web, const std::string& token_file, const std::string& env_token) {
  const int given = int(!token_file.empty()) + int(!web.token.empty()) + int(web.no_token);
  if (given > 1) throw UserError("give one of --web-token, --web-token-file and --no-web-token");
  if (!token_file.empty()) {
    std::ifstream in(token_file);
    if (!in) throw UserError(fmt::format("{}: cannot read the pages' token file", token_file));
    std::getline(in, web.token);
    while (!web.token.empty() && std::isspace(static_cast<unsigned char>(web.token.back()))) web.token.pop_back();
    if (web.token.empty()) throw UserError(fmt::format("{}: the token file's first line is empty", token_file));
  } else if (!env_token.empty() && web.token.empty() && !web.no_token) {
    web.token = env_token;
  }
  if (!web.token.empty() && web.token.size() < 8) throw UserError("the pages' token must be at least 8 characters");
  for (const char c : web.token)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_')
      throw UserError("the pages' token may hold letters, digits, '-' and '_' only (it goes into addresses)");
  return web;
}

bool is_loopback_address(const std::string& address) {
  if (address == "localhost" || address == "::1") return true;
  in_addr a{};
  if (inet_pton(AF_INET, address.c_str(), &a) != 1) return false;
  return (ntohl(a.s_addr) >> 24) == 127;
}

WebConsole::WebConsole(WebOptions options)
    : options_(std::move(options)), server_(std::make_unique<httplib::Server>()) {}

WebConsole::~WebConsole() { stop(); }

Result<std::unique_ptr<WebConsole>> WebConsole::bind(WebOptions options) {
  in_addr a4{};
  in6_addr a6{};
  if (options.bind != "localhost" && inet_pton(AF_INET, options.bind.c_str(), &a4) != 1 &&
      inet_pton(AF_INET6, options.bind.c_str(), &a6) != 1)
    return Error{
        fmt::format("--web-bind '{}' is not an IP address (e.g. 127.0.0.1, or this machine's address on "
                    "the lab network)",
                    options.bind)};
  if (options.port < 0 || options.port > 65535)
    return Error{fmt::format("--web-port {} is not a port (1-65535, or 0 for any free one)", options.port)};
  if (options.no_token && !is_loopback_address(options.bind))
    return Error{
        fmt::format("--no-web-token is for loopback only: pages on {} need the session's token", options.bind)};
  if (options.no_token)
    options.token.clear();
  else if (options.token.empty())
    options.token = random_token();
  std::unique_ptr<WebConsole> w(new WebConsole(std::move(options)));
  auto& o = w->options_;
  // Event streams hold a thread each for as long as a page is open: more than the default few.
  w->server_->new_task_queue = [] { return new httplib::ThreadPool(32); };
  w->server_->set_keep_alive_timeout(2);
  // One request per connection: a refused request's body (a 413) is never read as the next
  // request's line, which httplib would buffer whole. Pages on loopback lose nothing by it.
  w->server_->set_keep_alive_max_count(1);
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
  w->allowed_hosts_ = local_host_names(o.bind);
  // A body is refused past this before it is buffered (a chunked one too).
  w->server_->set_payload_max_length(kMaxBodyBytes);
  w->routes();
  return w;
}

bool WebConsole::allowed_host(const std::string& host_header) const {
  std::string host = host_header;
  if (!host.empty() && host.front() == '[') {  // [v6]:port
    const auto close = host.find(']');
    host = close == std::string::npos ? "" : host.substr(1, close - 1);
  } else if (const auto colon = host.rfind(':'); colon != std::string::npos) {
    host = host.substr(0, colon);
  }
  for (char& c : host) c = char(std::tolower(static_cast<unsigned char>(c)));
  return !host.empty() && std::find(allowed_hosts_.begin(), allowed_hosts_.end(), host) != allowed_hosts_.end();
}

std::string WebConsole::url(const std::string& page) const {
  const std::string host = options_.bind.find(':') != std::string::npos ? "[" + options_.bind + "]" : options_.bind;
  std::string u = fmt::format("http://{}:{}/{}", host, port_, page);
  if (!options_.token.empty()) u += "?token=" + options_.token;
  return u;
}

bool WebConsole::authorized(const std::string& query_token, const std::string& cookie,
                            const std::string& authorization) const {
  if (options_.token.empty()) return true;
  const std::string bearer = authorization.rfind("Bearer ", 0) == 0 ? authorization.substr(7) : "";
  return same_token(query_token, options_.token) || same_token(cookie, options_.token) ||
         same_token(bearer, options_.token);
}

void WebConsole::serve(PageSource& recording, Runner* runner) {
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
  std::optional<RunnerView> view;
  if (runner_) view = runner_->view();
  return status_model(recording_->status(), recording_->camera_count(), recording_->pressure_now(),
                      {participant_pages_.load(), operator_pages_.load()}, view ? &*view : nullptr)
      .dump();
}

void WebConsole::routes() {
  route_guard();
  route_pages();
  route_state();
  route_images();
  route_commands();
  route_api();
}

// Every request passes the checks first; an exception in a handler is answered, never fatal.
void WebConsole::route_guard() {
  auto& s = *server_;
  // Every request passes the token check first; the pages keep the token in a cookie so that
  // their images and event stream need not repeat it.
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    auto refuse = [&res](int status, const char* why) {
      res.status = status;
      res.set_header("Connection", "close");
      res.set_content(why, "text/plain; charset=utf-8");
      return httplib::Server::HandlerResponse::Handled;
    };
    // Only this machine's names: a DNS-rebinding page gives its own name as the Host.
    if (!allowed_host(req.get_header_value("Host")))
      return refuse(403, "these pages answer only to this machine's names (the address pvcap printed)\n");
    // Refused before the body is read: nothing a local process sends can fill the recorder's memory.
    if (req.has_header("Content-Length") &&
        std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10) > kMaxBodyBytes)
      return refuse(413, "a request to these pages is at most 64 KiB\n");
    // A command must come from the pages themselves: another site open in the operator's browser
    // could otherwise post "abort" to 127.0.0.1 (browsers name a cross-site sender in Origin).
    if (req.method == "POST" && req.has_header("Origin") &&
        req.get_header_value("Origin") != "http://" + req.get_header_value("Host")) {
      res.status = 403;
      res.set_content("commands are taken from this session's own pages only\n", "text/plain; charset=utf-8");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (authorized(req.get_param_value("token"), cookie_value(req.get_header_value("Cookie"), "pvcap_token"),
                   req.get_header_value("Authorization")))
      return httplib::Server::HandlerResponse::Unhandled;
    if (req.path.rfind("/api/", 0) == 0) log_refused_api_request(req);
    res.status = 401;
    res.set_content(
        "This pvcap session's pages need its token: open the address pvcap printed at the start "
        "(it ends in ?token=...).\n",
        "text/plain; charset=utf-8");
    return httplib::Server::HandlerResponse::Handled;
  });
  s.set_exception_handler([](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    // The details go to the log, not to whoever asked.
    spdlog::warn("the session's pages: {} {}: {}", req.method, req.path, what);
    res.status = 500;
    res.set_content("the request could not be answered (pvcap's log says why)\n", "text/plain");
  });
}

// The pages themselves, and the pictograms they show.
void WebConsole::log_refused_api_request(const httplib::Request& req) {
  std::lock_guard lock(refused_mu_);
  const auto now = std::chrono::steady_clock::now();
  if (now - refused_logged_ < std::chrono::seconds(5)) {
    ++refused_unlogged_;
    return;
  }
  spdlog::warn("remote-control API: {} {} from {} refused: no token or a wrong one{}", req.method, req.path,
               req.remote_addr,
               refused_unlogged_ ? fmt::format(" ({} more refused since the last such line)", refused_unlogged_) : "");
  refused_logged_ = now;
  refused_unlogged_ = 0;
}

void WebConsole::route_pages() {
  auto& s = *server_;
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

  s.Get(R"(/pictogram/(\d+))", [this](const httplib::Request& req, httplib::Response& res) {
    const std::size_t step = index_in_path(req.matches[1]);
    if (!runner_ || step >= runner_->plan().size()) {
      res.status = 404;
      return;
    }
    std::ifstream in(runner_->plan()[step].action->pictogram, std::ios::binary);
    if (!in) {
      res.status = 404;
      return;
    }
    std::ostringstream bytes;
    bytes << in.rdbuf();
    // The type its (checked, protocol/protocol.cpp) name says; an SVG opened on its own runs no script.
    const std::string ext = std::filesystem::path(runner_->plan()[step].action->pictogram).extension().string();
    const char* type = ext == ".png"                     ? "image/png"
                       : ext == ".jpg" || ext == ".jpeg" ? "image/jpeg"
                       : ext == ".webp"                  ? "image/webp"
                                                         : "image/svg+xml";
    res.set_header("Cache-Control", "max-age=3600");
    res.set_header("Content-Security-Policy", "script-src 'none'");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_content(bytes.str(), type);
  });
}

// The status model as JSON (console/web_status.h), polled or pushed as server-sent events.
void WebConsole::route_state() {
  auto& s = *server_;
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
    const bool participant = req.get_param_value("page") == "participant";
    std::atomic<int>& open = participant ? participant_pages_ : operator_pages_;
    if (open.load() >= (participant ? kMaxParticipantStreams : kMaxOtherStreams)) {
      res.status = 503;
      res.set_header("Connection", "close");
      res.set_content("too many pages of this session are open; close one\n", "text/plain; charset=utf-8");
      return;
    }
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
}

void WebConsole::route_images() {
  auto& s = *server_;
  // A camera's latest preview: the thumbnail, or (full) the whole frame for marking the fingertip.
  // X-Frame-Ns: when that frame arrived (host clock), which /fingertip sends back.
  auto camera_image = [this](const httplib::Request& req, httplib::Response& res, bool full) {
    if (req.matches[1].length() > 3) {
      res.status = 404;
      return;
    }
    const std::size_t camera = index_in_path(req.matches[1]);
    const auto [image, at] = recording_->preview(camera, full);
    const auto jpg = camera_jpeg(image, full);
    if (!jpg) {
      res.status = 404;
      res.set_content("no image from this camera yet\n", "text/plain");
      return;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Frame-Ns", std::to_string(at));
    res.set_content(*jpg, "image/jpeg");
  };
  s.Get(R"(/camera/(\d+)\.jpg)",
        [camera_image](const httplib::Request& req, httplib::Response& res) { camera_image(req, res, false); });
  s.Get(R"(/camera/(\d+)/full\.jpg)",
        [camera_image](const httplib::Request& req, httplib::Response& res) { camera_image(req, res, true); });

  // The latest pressure frame as a heat map (console/web_images.h).
  s.Get("/pressure.png", [this](const httplib::Request&, httplib::Response& res) {
    const auto p = recording_->pressure_now();
    const auto png = p ? pressure_png(*p) : std::nullopt;
    if (!png) {
      res.status = 404;
      res.set_content("no pressure frame yet\n", "text/plain");
      return;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_content(*png, "image/png");
  });
}

// What the pages send: the operator's commands and fingertip marks, the participant page's prompts.
void WebConsole::route_commands() {
  auto& s = *server_;
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
    if (!camera || !x || !y || !frame_ns || *camera < 0 || *camera >= double(n_cameras) ||
        *camera != std::floor(*camera) || *x < 0 || *y < 0 || *x > 100000 || *y > 100000 || *frame_ns <= 0) {
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

  // The operator's commands, the same as the terminal's keys. Acknowledged only once committed.
  s.Post("/command", [this](const httplib::Request& req, httplib::Response& res) {
    nlohmann::json reply;
    if (!parameters_are_text(req)) {
      res.status = 400;
      res.set_content(nlohmann::json{{"ok", false}, {"message", "a command is UTF-8 text"}}.dump(), "application/json");
      return;
    }
    const auto c = protocol::parse_command(req.get_param_value("command"));
    if (!runner_) {
      res.status = 409;
      reply = {{"ok", false}, {"message", "this session runs no protocol"}};
    } else if (!c) {
      res.status = 400;
      reply = {{"ok", false}, {"message", fmt::format("unknown command '{}'", req.get_param_value("command"))}};
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
    if (!parameters_are_text(req)) {
      res.status = 400;
      res.set_content("expected the step, sequence, phase and screen as UTF-8 text\n", "text/plain");
      return;
    }
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
}

}  // namespace pvcap::console
