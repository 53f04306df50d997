#include "sync/ptp_host.h"

#include <cmath>
#include <cstdlib>
#include <map>
#include <vector>

#include <fmt/format.h>

#include "core/subprocess.h"

namespace pvcap::sync {

namespace {

using Fields = std::map<std::string, std::string, std::less<>>;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// pmc's answers: a line "<port identity> seq N RESPONSE MANAGEMENT <ID>" opens one, its fields follow
// one per line, indented ("offsetFromMaster -58.0"). Lines of anything else end the answer.
std::map<std::string, Fields, std::less<>> answers_of(std::string_view text) {
  std::map<std::string, Fields, std::less<>> out;
  Fields* open = nullptr;
  while (!text.empty()) {
    const std::size_t eol = text.find('\n');
    const std::string_view raw = text.substr(0, eol);
    text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
    const bool indented = !raw.empty() && (raw.front() == '\t' || raw.front() == ' ');
    const std::string_view line = trim(raw);
    if (const std::size_t at = line.find(" RESPONSE MANAGEMENT "); at != std::string_view::npos) {
      const std::string_view id = trim(line.substr(at + 21));
      open = &out[std::string(id)];
      const std::string_view port = line.substr(0, line.find(' '));
      (*open)["(port)"] = std::string(port);
      continue;
    }
    if (!indented || line.empty()) {
      open = nullptr;
      continue;
    }
    if (!open) continue;
    const std::size_t space = line.find_first_of(" \t");
    if (space == std::string_view::npos) continue;
    (*open)[std::string(line.substr(0, space))] = std::string(trim(line.substr(space)));
  }
  return out;
}

Result<std::string> field(const std::map<std::string, Fields, std::less<>>& answers, const char* answer,
                          const char* name) {
  const auto a = answers.find(answer);
  if (a == answers.end()) return Error{fmt::format("ptp4l gave no {} (pmc printed no answer to GET {})", answer, answer)};
  const auto f = a->second.find(name);
  if (f == a->second.end() || f->second.empty()) return Error{fmt::format("pmc's {} has no {}", answer, name)};
  return f->second;
}

Result<double> number(const std::string& text, const char* answer, const char* name) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
    return Error{fmt::format("pmc's {} {} is not a number: '{}'", answer, name, text)};
  return v;
}

// "ae0e5a.fffe.382930-1" -> "ae0e5a.fffe.382930"
std::string clock_of(const std::string& port_identity) { return port_identity.substr(0, port_identity.rfind('-')); }

}  // namespace

Result<PtpHostState> parse_pmc_answer(std::string_view text) {
  const auto answers = answers_of(text);
  PtpHostState s;
  auto port_state = field(answers, "PORT_DATA_SET", "portState");
  if (!port_state) return port_state.error();
  s.port_state = port_state.value();
  auto port = field(answers, "PORT_DATA_SET", "portIdentity");
  if (!port) return port.error();
  s.clock_identity = clock_of(port.value());
  auto gm = field(answers, "PARENT_DATA_SET", "grandmasterIdentity");
  if (!gm) return gm.error();
  s.grandmaster = gm.value();
  auto present = field(answers, "TIME_STATUS_NP", "gmPresent");
  if (!present) return present.error();
  if (present.value() != "true" && present.value() != "false")
    return Error{fmt::format("pmc's TIME_STATUS_NP gmPresent is neither true nor false: '{}'", present.value())};
  s.gm_present = present.value() == "true";
  struct Number {
    const char* name;
    double* into;
  };
  double steps = 0;
  for (const Number& n : {Number{"offsetFromMaster", &s.offset_ns}, Number{"meanPathDelay", &s.path_delay_ns},
                          Number{"stepsRemoved", &steps}}) {
    auto text_of = field(answers, "CURRENT_DATA_SET", n.name);
    if (!text_of) return text_of.error();
    auto v = number(text_of.value(), "CURRENT_DATA_SET", n.name);
    if (!v) return v.error();
    *n.into = v.value();
  }
  if (steps < 0 || steps > 255 || steps != std::floor(steps))
    return Error{fmt::format("pmc's CURRENT_DATA_SET stepsRemoved is out of range: {}", steps)};
  s.steps_removed = int(steps);
  return s;
}

std::optional<std::string> ptp_host_out_of_time(const PtpHostState& s, double max_offset_ns) {
  if (s.is_grandmaster()) {
    if (s.port_state == "MASTER" || s.port_state == "GRAND_MASTER") return std::nullopt;
    return fmt::format("ptp4l is its own grandmaster but its port is {} (not serving time): see ptp4l's log",
                       s.port_state);
  }
  if (!s.gm_present)
    return fmt::format("ptp4l hears no grandmaster (its port is {}): is the PTP network up and its grandmaster running?",
                       s.port_state);
  if (s.port_state != "SLAVE" && s.port_state != "UNCALIBRATED")
    return fmt::format("ptp4l's port is {}, not following grandmaster {}: see ptp4l's log", s.port_state, s.grandmaster);
  // Both exactly zero: ptp4l has chosen its master but measured nothing yet (its first exchange of
  // Sync and Delay_Req is still to come); a measurement is never exactly zero in both.
  if (s.offset_ns == 0 && s.path_delay_ns == 0)
    return fmt::format("ptp4l follows grandmaster {} but has not measured its offset yet (wait for it)", s.grandmaster);
  if (std::abs(s.offset_ns) > max_offset_ns)
    return fmt::format(
        "{:.0f} ns from its master, over the limit of {:.0f} ns (ptp.max_offset_us): ptp4l has not locked yet (wait "
        "for it), or its timestamps are software ones on a loaded host",
        s.offset_ns, max_offset_ns);
  return std::nullopt;
}

std::string describe(const PtpHostState& s) {
  if (s.is_grandmaster()) return fmt::format("{} (the grandmaster, {})", s.port_state, s.clock_identity);
  return fmt::format("{} of {}{}, offset {:.0f} ns, path delay {:.0f} ns", s.port_state,
                     s.grandmaster.empty() ? "no grandmaster" : s.grandmaster, s.gm_present ? "" : " (not heard)",
                     s.offset_ns, s.path_delay_ns);
}

PmcClient::PmcClient(std::filesystem::path ptp4l_socket, std::chrono::milliseconds time_limit)
    : socket_(std::move(ptp4l_socket)), time_limit_(time_limit) {}

Result<PtpHostState> PmcClient::query() const {
  std::vector<std::string> args = {"pmc", "-u", "-b", "0", "-s", socket_.string()};
  for (const char* q : kPmcQueries) args.emplace_back(q);
  auto ran = run_program(args, time_limit_);
  if (!ran)
    return Error{fmt::format("cannot run pmc ({}): install linuxptp (apt-get install linuxptp)", ran.error().message)};
  const ProgramOutput& out = ran.value();
  if (out.timed_out)
    return Error{fmt::format("pmc did not answer within {} ms (ptp4l at {})", time_limit_.count(), socket_.string())};
  auto state = parse_pmc_answer(out.text);
  if (!state)
    return Error{fmt::format("no answer from ptp4l at {}: {} (is ptp4l running, with uds_address {}?)", socket_.string(),
                             state.error().message, socket_.string())};
  return state;
}

}  // namespace pvcap::sync
