#pragma once
// The session's pages, served by pvcap over HTTP (cpp-httplib):
//   /participant  what the participant sees: the action, its pictogram, force level, hand,
//                 repetition k of n, the countdown and the recording indicator, in large type;
//   /operator     protocol progress, live camera thumbnails, the live pressure heat map, drop
//                 counters and pairing offsets, and the operator's commands.
// Both follow the session through server-sent events (/events): no reloads.
//
// Bound on 127.0.0.1 by default. Every request carries the session's token (given, or generated
// and printed in the addresses; ?token=, then the HttpOnly SameSite=Strict cookie the pages set),
// on loopback too: any local user or process could otherwise watch the participant or abort the
// session. `no_token` turns that off, on loopback only. Requests are bounded before they are
// read: a Host that is not this machine's is refused (DNS rebinding), a body over kMaxBodyBytes is
// refused (413), and event streams are capped so the participant's page is always served.
//
// The socket is bound before the simulated rig moves pvcap into its private network
// namespace, so the pages open in the machine's own browser on the simulated rig too.
#include <atomic>
#include <chrono>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "console/page_source.h"
#include "core/result.h"

namespace httplib {
class Server;
struct Request;
}

namespace pvcap::protocol {
class Runner;
}

namespace pvcap::console {

struct WebOptions {
  std::string bind = "127.0.0.1";
  int port = 8090;        // busy: another free port is taken (and printed); 0: any free port
  std::string token;      // required of every request; generated when empty
  bool no_token = false;  // loopback only: no token at all (bind() refuses it elsewhere)
};

// The remote-control API's version: its routes are /api/v1/... (docs/remote.md).
inline constexpr int kRemoteApiVersion = 1;

// What a request may be: a command's form is a few hundred bytes.
inline constexpr std::size_t kMaxBodyBytes = 64 * 1024;
// Open event streams, each holding a server thread (of 32): the participant's page is counted
// apart, so other pages cannot take its place, and threads stay free for the pages themselves.
inline constexpr int kMaxParticipantStreams = 4;
inline constexpr int kMaxOtherStreams = 12;

bool is_loopback_address(const std::string& address);

// `options` with the pages' token chosen: from `token_file` (its first line) when given, else
// `env_token` (PVCAP_WEB_TOKEN, read by the caller) when options has none; at least 8 letters,
// digits, '-' or '_' (it goes into addresses). Throws UserError for two sources, an unreadable or
// empty file, or a token not so made.
WebOptions with_token(WebOptions options, const std::string& token_file, const std::string& env_token);

class WebConsole {
 public:
  // Binds the listening socket (nothing is served yet). A UserError-worthy failure (a bad address)
  // comes back as an error.
  static Result<std::unique_ptr<WebConsole>> bind(WebOptions options);
  ~WebConsole();
  WebConsole(const WebConsole&) = delete;
  WebConsole& operator=(const WebConsole&) = delete;

  // Starts serving the running recording, and its protocol when `runner` is set. Both must outlive stop().
  void serve(PageSource& recording, protocol::Runner* runner);
  // Ends the event streams and the server (idempotent).
  void stop();

  int port() const { return port_; }
  const std::string& token() const { return options_.token; }
  std::string url(const std::string& page) const;  // e.g. http://127.0.0.1:8090/participant[?token=...]

 private:
  explicit WebConsole(WebOptions options);
  void routes();
  void route_guard();
  void route_pages();
  void route_state();
  void route_images();
  void route_commands();
  void route_api();  // the remote-control API, /api/v1/ (console/web_api.cpp, docs/remote.md)
  std::string state_json() const;
  // The session's token in the query, the pages' cookie, or an `Authorization: Bearer` header (the API's).
  bool authorized(const std::string& query_token, const std::string& cookie, const std::string& authorization) const;
  bool allowed_host(const std::string& host_header) const;

  WebOptions options_;
  std::vector<std::string> allowed_hosts_;  // names a request's Host may give (without the port)
  int port_ = 0;
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<int> streams_{0};  // event streams open
  std::atomic<int> participant_pages_{0}, operator_pages_{0};
  // Requests to the remote-control API refused for their token: each logged, at most one line in
  // 5 s (the rest counted into the next), so a client retrying in a loop cannot flood the log.
  void log_refused_api_request(const httplib::Request& req);
  std::mutex refused_mu_;
  std::chrono::steady_clock::time_point refused_logged_{};
  int refused_unlogged_ = 0;
  PageSource* recording_ = nullptr;
  protocol::Runner* runner_ = nullptr;
};

}  // namespace pvcap::console
