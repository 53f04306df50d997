#include "dataset/completeness.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "lighting/lighting_code.h"

namespace pvcap::dataset {

using json = nlohmann::json;

namespace {

int rank(const std::string& status) {
  if (status == "done") return 3;
  if (status == "bad") return 2;
  if (status == "superseded") return 1;
  return 0;  // skipped, interrupted: as if not recorded
}

std::string folder_name(const std::string& folder) { return std::filesystem::path(folder).filename().string(); }

void session_flags(const DatasetConfig& c, const CatalogSession& s, std::vector<QaFlag>& flags) {
  const json facts = json::parse(s.facts_json, nullptr, false);
  if (!facts.is_object()) return;
  auto flag = [&](const std::string& kind, const std::string& message) {
    flags.push_back({s.participant, s.folder, kind, message});
  };
  const json verify = facts.value("verify", json::object());
  if (s.verify_exit == 1) {
    const auto errors = verify.value("errors", std::vector<std::string>{});
    flag("not_verified_clean", fmt::format("pvcap verify failed: {}", errors.empty() ? "?" : errors.front()));
  } else if (s.verify_exit == 3) {
    const auto losses = verify.value("losses", std::vector<std::string>{});
    flag("not_verified_clean", fmt::format("pvcap verify: lossy but readable ({} loss{}; first: {})", losses.size(),
                                           losses.size() == 1 ? "" : "es", losses.empty() ? "?" : losses.front()));
  }
  for (const auto& st : facts.value("streams", json::array())) {
    const double lost = st.value("lost_percent", 0.0);
    if (lost > c.thresholds.max_lost_percent)
      flag("losses",
           fmt::format("{}: {:.2f} % of its frames never arrived ({} frames; threshold {} %)", st.value("name", "?"),
                       lost, st.value("not_received", 0), c.thresholds.max_lost_percent));
  }
  for (const auto& cam : facts.value("self_check", json::array())) {
    if (!cam.contains("offset_ms") || !cam["offset_ms"].is_number()) continue;
    const double off = cam["offset_ms"].get<double>();
    const double unc =
        cam.contains("uncertainty_ms") && cam["uncertainty_ms"].is_number() ? cam["uncertainty_ms"].get<double>() : 0.0;
    if (std::abs(off) > c.thresholds.max_sync_offset_ms + 2 * unc)
      flag("sync_offset",
           fmt::format("{}: the sync self-check finds its frames {:+.2f} ms (+/- {:.2f}) off the pressure (threshold "
                       "{} ms)",
                       cam.value("name", "?"), off, unc, c.thresholds.max_sync_offset_ms));
  }
  std::vector<std::string> uncalibrated;
  for (const auto& cam : facts.value("calibration", json::array()))
    if (!cam.value("pad_calibrated", false)) uncalibrated.push_back(cam.value("name", "?"));
  if (!uncalibrated.empty())
    flag("no_calibration",
         fmt::format("no pad calibration for {} (`pvcap calibrate pad`)", fmt::join(uncalibrated, ", ")));
  if (!s.lighting_seen.empty() && !lighting::same_lighting(s.lighting, s.lighting_seen))
    flag("condition_mismatch", fmt::format("labelled lighting '{}', but its images show {} (docs/lighting.md)",
                                           s.lighting, s.lighting_seen));
  if (!c.conditions.empty() && std::find(c.conditions.begin(), c.conditions.end(), s.lighting) == c.conditions.end())
    flag("condition_unplanned", fmt::format("lighting '{}' is not one of the planned conditions ({})", s.lighting,
                                            fmt::join(c.conditions, ", ")));
}

ParticipantStatus participant_status(const protocol::Protocol& p, const std::string& code,
                                     const std::vector<const CatalogSession*>& sessions,
                                     const std::vector<CatalogTake>& takes, std::vector<QaFlag>& flags) {
  ParticipantStatus ps;
  ps.code = code;
  std::string hand_order = "right_first";
  std::set<std::string> mine;
  for (const CatalogSession* s : sessions) {
    ps.folders.push_back(s->folder);
    mine.insert(s->folder);
    if (ps.skin_tone.empty() || ps.skin_tone == "unrecorded") ps.skin_tone = s->skin_tone;
    // The condition its images showed where they were measured, else its label (splits stratify by it).
    const std::string& condition = s->lighting_seen.empty() ? s->lighting : s->lighting_seen;
    if (std::find(ps.lighting.begin(), ps.lighting.end(), condition) == ps.lighting.end())
      ps.lighting.push_back(condition);
    if (s->hand_order == "left_first" || s->hand_order == "right_first") hand_order = s->hand_order;
  }
  for (const auto& a : p.actions)
    for (const char* hand : {"left", "right"})
      if (std::string(hand) == "left" ? a.left_hand : a.right_hand) ps.cells[{hand, a.name}];
  std::map<std::string, std::vector<std::string>> lit_otherwise;  // per folder: takes whose images disagree
  for (const auto& t : takes) {
    if (!mine.count(t.folder)) continue;
    if (t.status == "done" && !t.lighting_seen.empty() && !lighting::same_lighting(t.lighting_commanded, t.lighting_seen))
      lit_otherwise[t.folder].push_back(
          fmt::format("{}: {} commanded, {} seen", t.sequence, t.lighting_commanded, t.lighting_seen));
    if (t.check_ok && !*t.check_ok && (t.status == "done" || t.status == "bad"))
      flags.push_back({code, t.folder, "take_check",
                       fmt::format("{}: {} with a failed take check{}", t.sequence, t.status,
                                   t.problems.empty() ? "" : ": " + t.problems.substr(0, t.problems.find('\n')))});
    Cell& cell = ps.cells[{t.hand, t.action}];
    cell.sequences.push_back(folder_name(t.folder) + "/" + t.sequence);
    if (t.status == "done") ++cell.done_takes;
    if (rank(t.status) > rank(cell.status)) cell.status = t.status;
  }
  for (const auto& [folder, which] : lit_otherwise)
    flags.push_back({code, folder, "condition_mismatch",
                     fmt::format("{} take(s) recorded under another lighting than commanded ({})", which.size(),
                                 fmt::join(which, "; "))});
  for (const auto& [key, cell] : ps.cells)
    if (cell.done_takes > 1)
      flags.push_back({code, "", "duplicate_take",
                       fmt::format("{} hand, {}: {} done takes ({}); a release exports each", key.first, key.second,
                                   cell.done_takes, fmt::join(cell.sequences, ", "))});
  for (const auto& planned : protocol::make_plan(p, hand_order)) {
    const std::string hand = protocol::to_string(planned.hand);
    if (ps.cells[{hand, planned.action->name}].status != "done") ps.remaining.push_back({planned.action->name, hand});
  }
  return ps;
}

}  // namespace

DatasetStatus compute_status(const DatasetConfig& c, const protocol::Protocol& p,
                             const std::vector<CatalogSession>& sessions, const std::vector<CatalogTake>& takes,
                             const std::vector<Withdrawal>& withdrawals) {
  DatasetStatus out;
  out.name = c.name;
  for (const auto& a : p.actions) out.actions.push_back(a.name);
  std::map<std::string, std::vector<const CatalogSession*>> by_participant;
  for (const auto& s : sessions) {
    if (is_withdrawn(withdrawals, s.participant)) continue;
    by_participant[s.participant].push_back(&s);
    ++out.sessions;
  }
  std::set<std::string> withdrawn;
  for (const auto& w : withdrawals) withdrawn.insert(w.participant);
  out.withdrawn = withdrawn.size();
  for (const auto& code : c.planned_participants)
    if (!withdrawn.count(code)) by_participant[code];
  const std::set<std::string> planned(c.planned_participants.begin(), c.planned_participants.end());
  for (auto& [code, list] : by_participant) {
    std::sort(list.begin(), list.end(), [](const CatalogSession* a, const CatalogSession* b) {
      return std::tie(a->started_wall_ns, a->folder) < std::tie(b->started_wall_ns, b->folder);
    });
    for (const CatalogSession* s : list) session_flags(c, *s, out.flags);
    ParticipantStatus ps = participant_status(p, code, list, takes, out.flags);
    ps.planned = planned.empty() || planned.count(code);
    if (!ps.planned)
      out.flags.push_back({code, "", "unplanned", "recorded, but not among dataset.yaml's participants"});
    if (list.empty()) out.flags.push_back({code, "", "no_sessions", "planned, no session recorded yet"});
    out.participants.push_back(std::move(ps));
  }
  return out;
}

json status_json(const DatasetStatus& s) {
  json participants = json::array();
  for (const auto& p : s.participants) {
    json cells = json::object();
    for (const auto& [key, cell] : p.cells)
      cells[key.first][key.second] = {
          {"status", cell.status}, {"done_takes", cell.done_takes}, {"takes", cell.sequences}};
    json remaining = json::array();
    for (const auto& [action, hand] : p.remaining) remaining.push_back({{"action", action}, {"hand", hand}});
    participants.push_back({{"participant", p.code},
                            {"skin_tone", p.skin_tone},
                            {"lighting", p.lighting},
                            {"planned", p.planned},
                            {"sessions", p.folders},
                            {"cells", cells},
                            {"remaining", remaining},
                            {"complete", p.remaining.empty()}});
  }
  json flags = json::array();
  for (const auto& f : s.flags)
    flags.push_back({{"participant", f.participant}, {"folder", f.folder}, {"kind", f.kind}, {"message", f.message}});
  return {{"dataset", s.name},        {"actions", s.actions},         {"sessions", s.sessions},
          {"withdrawn", s.withdrawn}, {"participants", participants}, {"flags", flags}};
}

namespace {
char symbol(const std::string& status) {
  if (status == "done") return '#';
  if (status == "bad") return 'B';
  if (status == "superseded") return 's';
  return '.';
}
}  // namespace

std::string format_status(const DatasetStatus& s) {
  std::string out = fmt::format("dataset {}: {} participants, {} sessions{}\n", s.name, s.participants.size(),
                                s.sessions, s.withdrawn ? fmt::format(", {} withdrawn", s.withdrawn) : "");
  out += "  # done   B bad   s superseded   . missing   (one column per action; left hand | right hand)\n";
  for (const auto& p : s.participants) {
    std::string left, right;
    for (const auto& a : s.actions) {
      const auto l = p.cells.find({"left", a}), r = p.cells.find({"right", a});
      left += l == p.cells.end() ? ' ' : symbol(l->second.status);
      right += r == p.cells.end() ? ' ' : symbol(r->second.status);
    }
    out += fmt::format("  {:<12} {} | {}  {}\n", p.code, left, right,
                       p.remaining.empty() ? "complete" : fmt::format("{} takes to record", p.remaining.size()));
  }
  if (!s.flags.empty()) {
    out += fmt::format("QA flags ({}):\n", s.flags.size());
    for (const auto& f : s.flags)
      out += fmt::format("  {} {}{}: {}\n", f.participant, f.kind,
                         f.folder.empty() ? "" : " (" + folder_name(f.folder) + ")", f.message);
  }
  return out;
}

std::string remaining_protocol_yaml(const protocol::Protocol& p, const ParticipantStatus& ps,
                                    const std::string& pictogram_folder) {
  if (ps.remaining.empty()) return "";
  auto timings = [](YAML::Emitter& y, const protocol::Timings& t) {
    y << YAML::Flow << YAML::BeginMap << YAML::Key << "prompt_s" << YAML::Value << t.prompt_s << YAML::Key
      << "countdown_s" << YAML::Value << t.countdown_s << YAML::Key << "record_s" << YAML::Value << t.record_s
      << YAML::Key << "rest_s" << YAML::Value << t.rest_s << YAML::EndMap;
  };
  YAML::Emitter y;
  y.SetDoublePrecision(6);
  y << YAML::BeginMap;
  y << YAML::Key << "name" << YAML::Value << p.name;
  y << YAML::Key << "timings" << YAML::Value;
  timings(y, p.timings);
  y << YAML::Key << "fast_timings" << YAML::Value;
  timings(y, p.fast_timings);
  y << YAML::Key << "take_check" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "contact_newtons" << YAML::Value << p.check.contact_newtons;
  y << YAML::Key << "no_contact_newtons" << YAML::Value << p.check.no_contact_newtons;
  y << YAML::Key << "high_over_low" << YAML::Value << p.check.high_over_low;
  y << YAML::Key << "max_gap_ms" << YAML::Value << p.check.max_gap_ms;
  y << YAML::EndMap;
  y << YAML::Key << "actions" << YAML::Value << YAML::BeginSeq;
  // One entry per remaining action row, with the hands it still lacks, in the protocol's order.
  for (const auto& a : p.actions) {
    std::vector<std::string> hands;
    for (const auto& [action, hand] : ps.remaining)
      if (action == a.name) hands.push_back(hand);
    if (hands.empty()) continue;
    std::sort(hands.begin(), hands.end());
    y << YAML::BeginMap;
    y << YAML::Key << "name" << YAML::Value << a.group;
    y << YAML::Key << "text" << YAML::Value << a.text;
    y << YAML::Key << "pictogram" << YAML::Value
      << pictogram_folder + "/" + std::filesystem::path(a.pictogram).filename().string();
    if (a.force != protocol::Force::Any)
      y << YAML::Key << "forces" << YAML::Value << YAML::Flow << std::vector<std::string>{protocol::to_string(a.force)};
    y << YAML::Key << "repetitions" << YAML::Value << a.repetitions;
    y << YAML::Key << "check_side" << YAML::Value << a.check_side;
    if (!a.lighting.empty()) y << YAML::Key << "lighting" << YAML::Value << a.lighting;
    y << YAML::Key << "hands" << YAML::Value << YAML::Flow << hands;
    y << YAML::Key << "timings" << YAML::Value;
    timings(y, a.timings);
    y << YAML::EndMap;
  }
  y << YAML::EndSeq << YAML::EndMap;
  return fmt::format(
      "# The takes participant {} still lacks (pvcap dataset status), from protocol {}.\n"
      "# Run: pvcap session --protocol THIS_FILE --participant {} ...\n{}\n",
      ps.code, p.source.filename().string(), ps.code, y.c_str());
}

}  // namespace pvcap::dataset
