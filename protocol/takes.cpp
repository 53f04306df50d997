#include "protocol/takes.h"

#include <map>

#include <fmt/format.h>

#include "codec/sensel_units.h"
#include "storage/index/session_reader.h"

namespace pvcap::protocol {

namespace {

nlohmann::json parse_detail(const std::string& s) {
  auto j = nlohmann::json::parse(s, nullptr, /*allow_exceptions=*/false);
  return j.is_discarded() || !j.is_object() ? nlohmann::json::object() : j;
}

Status read_one(const std::filesystem::path& dir, SessionTakes& out, int depth) {
  auto opened = SessionReader::open(dir);
  if (!opened) return opened.error();
  SessionReader& r = *opened.value();
  auto events = r.protocol_events();
  if (!events) return events.error();
  nlohmann::json start;
  for (const auto& e : events.value())
    if (e.kind == "protocol_start") start = parse_detail(e.detail);
  if (start.is_null())
    return Error{fmt::format("{}: no protocol was run in this session (it has no protocol_start event)", dir.string())};
  // A continuation: the folders it continues come first.
  if (start.contains("continues") && depth < 100) {
    const std::filesystem::path previous = start["continues"].get<std::string>();
    if (Status s = read_one(previous, out, depth + 1); !s.ok()) return s;
  }
  out.folders.push_back(dir.string());
  out.protocol_start = start;
  out.plan_steps = start.value("takes", 0);
  const std::int64_t session_end = r.info().ended_host_ns.value_or(INT64_MAX);
  std::map<std::string, std::size_t> by_sequence;  // the latest row of each sequence name in this folder
  std::vector<TakeRow> rows;
  auto row_of = [&](const ProtocolEventRecord& e, const std::string& sequence) {
    TakeRow t;
    t.session = dir.string();
    t.step = int(e.step.value_or(-1));
    t.sequence = sequence;
    t.action = e.action;
    t.hand = e.hand;
    t.force = e.force;
    t.repetitions = int(e.repetition.value_or(0));
    return t;
  };
  for (const auto& e : events.value()) {
    const auto d = parse_detail(e.detail);
    const std::string sequence = d.value("take", "");
    if (e.kind == "action_start") {
      TakeRow t = row_of(e, sequence);
      t.status = "interrupted";  // until its end says otherwise (a killed session's last take stays so)
      t.start_ns = e.host_ns;
      t.lighting_commanded = d.value("lighting", "");
      by_sequence[sequence] = rows.size();
      rows.push_back(std::move(t));
    } else if (e.kind == "action_end" && by_sequence.count(sequence)) {
      TakeRow& t = rows[by_sequence[sequence]];
      t.status = d.value("status", "done");
      t.end_ns = e.host_ns;
      if (d.contains("lighting") && d["lighting"].is_object()) {
        t.lighting_commanded = d["lighting"].value("commanded", t.lighting_commanded);
        t.lighting_seen = d["lighting"].value("seen", "");
        for (std::size_t i = 0; i < t.lighting_commanded.size() && i < t.lighting_seen.size(); ++i)
          if (t.lighting_commanded[i] != t.lighting_seen[i])
            t.lights_disagreeing += t.lighting_commanded[i] != '-' ? t.lighting_commanded[i] : t.lighting_seen[i];
      }
      if (d.contains("check")) {
        t.check_ok = d["check"].value("ok", true);
        if (d["check"].contains("problems") && d["check"]["problems"].is_array())
          for (const auto& p : d["check"]["problems"])
            if (p.is_string()) t.check_problems.push_back(p.get<std::string>());
      }
    } else if (e.kind == "skip") {
      TakeRow t = row_of(e, sequence);
      t.status = "skipped";
      rows.push_back(std::move(t));
    } else if ((e.kind == "superseded" || e.kind == "mark_bad") && by_sequence.count(sequence)) {
      rows[by_sequence[sequence]].status = e.kind == "superseded" ? "superseded" : "bad";
    }
  }
  for (auto& t : rows) {
    t.session_start_ns = r.info().started_host_ns;
    if (!t.start_ns) continue;
    const std::int64_t end = t.end_ns.value_or(session_end);
    if (r.sample_count()) {
      // A read that fails here is an error, never a take a sample shorter (a disk's EIO once did that).
      auto first = r.sample_at(*t.start_ns);
      if (!first) return first.error();
      auto last = r.sample_at(end);
      if (!last) return last.error();
      std::size_t a = first.value(), b = last.value();
      auto at_a = r.sample_info(a);
      if (!at_a) return at_a.error();
      if (at_a.value().t_ns < *t.start_ns) ++a;
      auto at_b = r.sample_info(b);
      if (!at_b) return at_b.error();
      if (at_b.value().t_ns < end) ++b;
      t.first_sample = a;
      t.end_sample = std::max(a, b);
    }
    if (!r.pressure_device() || end == INT64_MAX) continue;
    auto frames = r.pressure_frames_between(*t.start_ns, end);
    if (!frames) return frames.error();
    double sum = 0, contact = 0;
    for (const auto& f : frames.value()) {
      const sensel::Grid g{f.grid_cols, f.grid_rows, f.grid_xscale, f.grid_yscale};
      const auto s = sensel::summarize_pressure(f.counts, g);
      sum += s.total_newtons;
      contact += s.contact_area_mm2;
      t.peak_newtons = std::max(t.peak_newtons, s.total_newtons);
      t.peak_contact_mm2 = std::max(t.peak_contact_mm2, s.contact_area_mm2);
    }
    t.pressure_frames = frames.value().size();
    if (t.pressure_frames) {
      t.mean_newtons = sum / double(t.pressure_frames);
      t.mean_contact_mm2 = contact / double(t.pressure_frames);
    }
  }
  for (auto& t : rows) out.takes.push_back(std::move(t));
  return {};
}

}  // namespace

Result<SessionTakes> read_takes(const std::filesystem::path& session_dir) {
  SessionTakes out;
  if (Status s = read_one(session_dir, out, 0); !s.ok()) return s.error();
  return out;
}

int first_incomplete_step(const SessionTakes& t) {
  std::vector<bool> complete(std::size_t(std::max(t.plan_steps, 0)), false);
  for (const auto& row : t.takes)
    if ((row.status == "done" || row.status == "bad") && row.step >= 0 && row.step < int(complete.size()))
      complete[std::size_t(row.step)] = true;
  for (std::size_t i = 0; i < complete.size(); ++i)
    if (!complete[i]) return int(i);
  return int(complete.size());
}

namespace {
struct ForceSummary {
  int takes = 0;
  double mean = 0, peak = 0;
};
std::map<std::string, ForceSummary> by_force(const SessionTakes& t) {
  std::map<std::string, ForceSummary> m;
  for (const auto& row : t.takes) {
    if (row.status != "done" || row.pressure_frames == 0) continue;
    auto& s = m[row.force];
    s.mean += row.mean_newtons;
    s.peak = std::max(s.peak, row.peak_newtons);
    ++s.takes;
  }
  for (auto& [f, s] : m) s.mean /= std::max(1, s.takes);
  return m;
}
}  // namespace

std::string format_takes(const SessionTakes& t) {
  fmt::memory_buffer b;
  auto out = std::back_inserter(b);
  for (const auto& f : t.folders) fmt::format_to(out, "session: {}\n", f);
  fmt::format_to(out, "{:>4} {:<44} {:<11} {:>9} {:>9} {:>13} {:>9} {:>9} {:>10}\n", "step", "take", "status",
                 "start s", "end s", "samples", "mean N", "peak N", "peak mm2");
  for (const auto& r : t.takes) {
    auto secs = [&](const std::optional<std::int64_t>& ns) {
      return ns ? fmt::format("{:.2f}", double(*ns - r.session_start_ns) / 1e9) : std::string("-");
    };
    const std::string samples =
        r.first_sample ? fmt::format("{}..{}", *r.first_sample, r.end_sample.value_or(*r.first_sample)) : "-";
    fmt::format_to(out, "{:>4} {:<44} {:<11} {:>9} {:>9} {:>13} {:>9.2f} {:>9.2f} {:>10.0f}\n", r.step, r.sequence,
                   r.status, secs(r.start_ns), secs(r.end_ns), samples, r.mean_newtons, r.peak_newtons,
                   r.peak_contact_mm2);
  }
  int done = 0;
  for (const auto& r : t.takes) done += r.status == "done";
  fmt::format_to(out, "{} takes done of {} in the plan ({} rows)\n", done, t.plan_steps, t.takes.size());
  fmt::format_to(out, "mean total force while recording, by requested force level (done takes):\n");
  for (const auto& [force, s] : by_force(t))
    fmt::format_to(out, "  {:<11} {:>3} takes  mean {:6.2f} N  peak {:6.2f} N\n", force, s.takes, s.mean, s.peak);
  return fmt::to_string(b);
}

nlohmann::json takes_json(const SessionTakes& t) {
  nlohmann::json j;
  j["folders"] = t.folders;
  j["plan_steps"] = t.plan_steps;
  j["takes"] = nlohmann::json::array();
  for (const auto& r : t.takes) {
    nlohmann::json row = {{"session", r.session},
                          {"step", r.step},
                          {"sequence", r.sequence},
                          {"action", r.action},
                          {"hand", r.hand},
                          {"force", r.force},
                          {"repetitions", r.repetitions},
                          {"status", r.status},
                          {"mean_newtons", r.mean_newtons},
                          {"peak_newtons", r.peak_newtons},
                          {"mean_contact_mm2", r.mean_contact_mm2},
                          {"peak_contact_mm2", r.peak_contact_mm2},
                          {"pressure_frames", r.pressure_frames}};
    // Seconds from the start of the take's own folder; the session clock's ns as stored.
    row["start_s"] = r.start_ns ? nlohmann::json(double(*r.start_ns - r.session_start_ns) / 1e9) : nlohmann::json();
    row["end_s"] = r.end_ns ? nlohmann::json(double(*r.end_ns - r.session_start_ns) / 1e9) : nlohmann::json();
    row["start_ns"] = r.start_ns ? nlohmann::json(*r.start_ns) : nlohmann::json();
    row["end_ns"] = r.end_ns ? nlohmann::json(*r.end_ns) : nlohmann::json();
    row["first_sample"] = r.first_sample ? nlohmann::json(*r.first_sample) : nlohmann::json();
    row["end_sample"] = r.end_sample ? nlohmann::json(*r.end_sample) : nlohmann::json();
    row["check_ok"] = r.check_ok ? nlohmann::json(*r.check_ok) : nlohmann::json();
    row["check_problems"] = r.check_problems;
    if (!r.lighting_commanded.empty())
      row["lighting"] = {{"commanded", r.lighting_commanded},
                         {"seen", r.lighting_seen},
                         {"lights_disagreeing", r.lights_disagreeing}};
    j["takes"].push_back(row);
  }
  for (const auto& [force, s] : by_force(t))
    j["by_force"][force] = {{"takes", s.takes}, {"mean_newtons", s.mean}, {"peak_newtons", s.peak}};
  return j;
}

}  // namespace pvcap::protocol
