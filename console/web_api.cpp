// The remote-control API (version 1, docs/remote.md): what experiment software asks of a running
// session over the pages' own server. The same guard as the pages (this machine's names only, the
// session's token, here as `Authorization: Bearer TOKEN`, bodies of at most 64 KiB); every request
// that changes something is logged and committed to the session as a protocol event before it is
// answered.
#include <fmt/format.h>
#include <httplib.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "console/web_console.h"
#include "console/web_request.h"
#include "protocol/runner.h"

namespace pvcap::console {
namespace {

using nlohmann::json;

void reply(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body.dump(), "application/json");
}

json status_json(const session::RecordingStatus& st, const protocol::Runner* runner) {
  json streams = json::array();
  for (const auto& s : st.streams)
    streams.push_back({{"name", s.name},
                       {"kind", s.kind},
                       {"good", s.good},
                       {"lost", s.not_received + s.incomplete + s.queue_overflow + s.buffer_underrun},
                       {"rate_hz", s.rate_hz},
                       {"since_last_frame_ms", s.since_last_frame_ms}});
  json out = {{"api", kRemoteApiVersion},  {"state", st.state},     {"session", st.session_dir},
              {"elapsed_s", st.elapsed_s}, {"samples", st.samples}, {"streams", streams},
              {"warnings", st.warnings}};
  if (runner) {
    const protocol::RunnerView v = runner->view();
    out["protocol"] = {{"step", v.step}, {"steps", v.steps}, {"takes_done", v.takes_done}, {"action", v.action_name}};
  }
  return out;
}

}  // namespace

void WebConsole::route_api() {
  auto& s = *server_;
  s.Get("/api/v1/status", [this](const httplib::Request&, httplib::Response& res) {
    reply(res, 200, status_json(recording_->status(), runner_));
  });

  // Commits `kind` with `detail` on the capture clock; false (answered 503) when the store could not.
  auto commit = [this](httplib::Response& res, const char* kind, const json& detail) {
    ProtocolEventRecord e;
    e.kind = kind;
    e.detail = detail.dump();
    if (recording_->post(std::move(e))) return true;
    reply(res, 503, {{"ok", false}, {"message", "the session could not commit it (its store is behind or failed)"}});
    return false;
  };
  auto text_only = [](const httplib::Request& req, httplib::Response& res) {
    if (parameters_are_text(req)) return true;
    reply(res, 400, {{"ok", false}, {"message", "parameters are UTF-8 text"}});
    return false;
  };

  // A mark: what the experiment software says happened (a stimulus, a trial's start), on the session's clock.
  s.Post("/api/v1/mark", [this, commit, text_only](const httplib::Request& req, httplib::Response& res) {
    if (!text_only(req, res)) return;
    const std::string label = req.get_param_value("label");
    if (label.empty()) return reply(res, 400, {{"ok", false}, {"message", "a mark needs a label"}});
    spdlog::info("remote-control API: mark '{}'", label);
    if (commit(res, "remote_mark", {{"label", label}, {"note", req.get_param_value("note")}}))
      reply(res, 200, {{"ok", true}});
  });

  // The protocol's commands, as the operator's keys and page give them.
  s.Post("/api/v1/command", [this, commit, text_only](const httplib::Request& req, httplib::Response& res) {
    if (!text_only(req, res)) return;
    const std::string name = req.get_param_value("command"), argument = req.get_param_value("argument");
    if (!runner_) return reply(res, 409, {{"ok", false}, {"message", "this session runs no protocol"}});
    const auto c = protocol::parse_command(name);
    if (!c) return reply(res, 400, {{"ok", false}, {"message", fmt::format("unknown command '{}'", name)}});
    const auto r = runner_->command(*c, argument);
    spdlog::info("remote-control API: command {} -> {}{}", name, r.ok ? "" : "refused: ", r.message);
    if (commit(res, "remote_command",
               {{"command", name}, {"argument", argument}, {"ok", r.ok}, {"message", r.message}}))
      reply(res, r.ok ? 200 : 409, {{"ok", r.ok}, {"message", r.message}});
  });

  // Stop: the session ends as Ctrl-C ends it, with the reason given.
  s.Post("/api/v1/stop", [this, commit, text_only](const httplib::Request& req, httplib::Response& res) {
    if (!text_only(req, res)) return;
    const std::string reason = req.get_param_value("reason");
    spdlog::info("remote-control API: stop{}", reason.empty() ? "" : " (" + reason + ")");
    if (!commit(res, "remote_stop", {{"reason", reason}})) return;
    recording_->request_stop("stopped through the remote-control API" + (reason.empty() ? "" : ": " + reason));
    reply(res, 200, {{"ok", true}});
  });
}

}  // namespace pvcap::console
