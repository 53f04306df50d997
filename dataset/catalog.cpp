#include "dataset/catalog.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <future>
#include <map>
#include <mutex>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "lighting/lighting_code.h"
#include "protocol/takes.h"
#include "report/session_report_data.h"
#include "storage/index/session_reader.h"
#include "storage/tools/verify.h"

namespace pvcap::dataset {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

bool is_session(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / "session.db", ec);
}

void find_under(const fs::path& dir, int depth, std::vector<fs::path>& out) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path p = it->path();
    if (p.filename().string().rfind('.', 0) == 0 || !it->is_directory(ec)) continue;
    if (is_session(p))
      out.push_back(fs::absolute(p).lexically_normal());
    else if (depth > 1)
      find_under(p, depth - 1, out);
  }
}

// Per stream: what the devices numbered and never arrived, in all and by reason.
json stream_losses(const json& streams) {
  json out = json::array();
  for (const auto& s : streams) {
    const double frames = s.value("frames", 0.0), lost = s.value("not_received", 0.0);
    out.push_back({{"name", s.value("name", "")},
                   {"kind", s.value("kind", "")},
                   {"frames", s.value("frames", 0)},
                   {"not_received", s.value("not_received", 0)},
                   {"lost_percent", frames + lost > 0 ? 100.0 * lost / (frames + lost) : 0.0},
                   {"by_reason", s.value("not_received_by_reason", json::object())}});
  }
  return out;
}

json self_check_offsets(const json& report) {
  json out = json::array();
  if (!report.contains("self_check")) return out;
  for (const auto& c : report["self_check"].value("cameras", json::array()))
    out.push_back({{"name", c.value("name", "")},
                   {"offset_ms", c.value("offset_ms", json(nullptr))},
                   {"uncertainty_ms", c.value("uncertainty_ms", json(nullptr))},
                   {"verdict", c.value("verdict", "")}});
  return out;
}

json calibration_summary(const json& report) {
  json out = json::array();
  for (const auto& c : report.value("calibration", json::array())) {
    json last = nullptr;
    for (const auto& m : c.value("measurements", json::array())) last = m;
    out.push_back(
        {{"name", c.value("name", "")}, {"pad_calibrated", c.value("pad_calibrated", false)}, {"latest", last}});
  }
  return out;
}

std::string participant_of(const fs::path& folder) {
  auto reader = SessionReader::open(folder);
  if (!reader || !reader.value()->info().participant) return "unrecorded";
  return reader.value()->info().participant->pseudonym;
}

}  // namespace

std::string ScanResult::summary() const {
  return fmt::format("catalogue: {} session folders ({} read, {} unchanged{}{}) in {:.1f} s", found, read, unchanged,
                     forgotten ? fmt::format(", {} forgotten", forgotten) : "",
                     withdrawn ? fmt::format(", {} of withdrawn participants left out", withdrawn) : "", seconds);
}

std::vector<fs::path> find_sessions(const std::vector<fs::path>& roots) {
  std::vector<fs::path> out;
  for (const auto& r : roots) {
    if (is_session(r))
      out.push_back(fs::absolute(r).lexically_normal());
    else
      find_under(r, 2, out);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string session_fingerprint(const fs::path& folder) {
  std::vector<std::string> parts;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const bool counts = name == "session.db" || name == "session.db-wal" || it->path().extension() == ".mkv";
    struct stat st {};
    if (!counts || ::stat(it->path().c_str(), &st) != 0) continue;
    parts.push_back(fmt::format("{}:{}:{}.{:09}", name, st.st_size, st.st_mtim.tv_sec, st.st_mtim.tv_nsec));
  }
  std::sort(parts.begin(), parts.end());
  std::string out;
  for (const auto& p : parts) out += p + ";";
  return out;
}

namespace {
// The lighting a session's images showed: the code seen most often among its done takes recorded
// under its label (any of its done takes when none was); "" when no take's images were measured.
std::string measured_lighting(const std::string& label, const std::vector<CatalogTake>& takes) {
  std::map<std::string, int> under_label, any;
  for (const auto& t : takes) {
    if (t.status != "done" || t.lighting_seen.empty()) continue;
    ++any[t.lighting_seen];
    if (lighting::same_lighting(t.lighting_commanded, label)) ++under_label[t.lighting_seen];
  }
  const auto& counts = under_label.empty() ? any : under_label;
  std::string best;
  int most = 0;
  for (const auto& [code, n] : counts)
    if (n > most) best = code, most = n;
  return best;
}
}  // namespace

Result<std::pair<CatalogSession, std::vector<CatalogTake>>> read_session(
    const fs::path& folder, const std::function<void(const std::string&)>& step) {
  CatalogSession s;
  s.folder = fs::absolute(folder).lexically_normal().string();
  s.fingerprint = session_fingerprint(folder);
  {
    auto reader = SessionReader::open(folder);
    if (!reader) return reader.error();
    const auto& info = reader.value()->info();
    s.started_wall_ns = info.started_wall_ns;
    s.participant = info.participant ? info.participant->pseudonym : "unrecorded";
    s.skin_tone = info.participant ? info.participant->skin_tone : "unrecorded";
    s.hand_order = info.participant ? info.participant->hand_order : "unrecorded";
    s.lighting = info.conditions ? info.conditions->lighting : "unrecorded";
    s.overlay = info.conditions ? info.conditions->sensor_overlay : "unrecorded";
  }
  // The two that decode video run side by side (each with its own reader): verify decodes every
  // kept frame, the report's self-check the frames around the presses.
  auto verified = std::async(std::launch::async, [&folder, &step] {
    return verify_session(folder, [&step](const std::string& s) {
      if (step) step("verify: " + s);
    });
  });
  json report;
  try {
    report::ReportOptions o;
    o.thumbnails = false;
    o.progress = [&step](const std::string& what, std::size_t done, std::size_t total) {
      if (step) step(fmt::format("report: {} ({}/{})", what, done, total));
    };
    auto r = report::build_report(folder, o);
    if (!r) return r.error();
    report = std::move(r.value());
  } catch (const UserError& e) {
    return Error{e.what()};
  }
  const VerifyReport v = verified.get();
  s.verify_exit = v.exit_code();
  json facts = {{"verify", {{"exit", s.verify_exit}, {"losses", v.losses}, {"errors", v.errors}}}};
  facts["streams"] = stream_losses(report.value("streams", json::array()));
  facts["self_check"] = self_check_offsets(report);
  facts["calibration"] = calibration_summary(report);
  facts["end_reason"] = report.value("session", json::object()).value("end_reason", "");
  s.facts_json = facts.dump();

  std::vector<CatalogTake> takes;
  s.original = s.folder;
  auto t = protocol::read_takes(folder);
  if (t) {
    const auto& st = t.value();
    if (!st.folders.empty()) s.original = fs::absolute(st.folders.front()).lexically_normal().string();
    s.protocol = st.protocol_start.value("protocol", "");
    for (const auto& row : st.takes) {
      if (fs::absolute(row.session).lexically_normal().string() != s.folder) continue;  // an earlier folder's
      std::string problems;
      for (const auto& p : row.check_problems) problems += (problems.empty() ? "" : "\n") + p;
      takes.push_back({s.folder, row.step, row.sequence, row.action, row.hand, row.force, row.status, row.check_ok,
                       problems, row.start_ns, row.lighting_commanded, row.lighting_seen});
    }
  }
  s.lighting_seen = measured_lighting(s.lighting, takes);
  return std::make_pair(std::move(s), std::move(takes));
}

Result<ScanResult> scan(const DatasetConfig& c, CatalogDb& db, const ScanProgress& progress,
                        const std::atomic<bool>& stop) {
  const auto started = std::chrono::steady_clock::now();
  ScanResult out;
  const auto withdrawals = load_withdrawals(c.dir);
  const auto folders = find_sessions(c.session_roots);
  out.found = folders.size();
  std::vector<std::string> keep;
  for (std::size_t i = 0; i < folders.size() && !stop.load(); ++i) {
    const std::string folder = folders[i].string();
    if (progress) progress(i, folders.size(), folders[i].filename().string());
    const auto known = db.fingerprint(folder);
    if (known && *known == session_fingerprint(folders[i])) {
      keep.push_back(folder);
      ++out.unchanged;
      continue;
    }
    if (is_withdrawn(withdrawals, participant_of(folders[i]))) {  // never read again
      ++out.withdrawn;
      continue;
    }
    // What each of the two readers is at (they run on two threads), said as the folder's progress.
    std::mutex said;
    auto r = read_session(folders[i], [&](const std::string& step) {
      std::lock_guard lock(said);
      if (progress) progress(i, folders.size(), folders[i].filename().string() + ": " + step);
    });
    if (!r) {
      // Damaged beyond reading: catalogued as such (status flags it), not left out of sight.
      out.problems.push_back(fmt::format("{}: cannot be read: {}", folder, r.error().message));
      CatalogSession damaged;
      damaged.folder = damaged.original = folder;
      damaged.fingerprint = session_fingerprint(folders[i]);
      damaged.participant = participant_of(folders[i]);
      damaged.skin_tone = damaged.hand_order = damaged.lighting = damaged.overlay = "unrecorded";
      damaged.verify_exit = 1;
      damaged.facts_json =
          json{{"verify", {{"exit", 1}, {"losses", json::array()}, {"errors", {r.error().message}}}}}.dump();
      r = std::make_pair(std::move(damaged), std::vector<CatalogTake>{});
    }
    if (auto p = db.put(r.value().first, r.value().second); !p.ok()) return p.error();
    keep.push_back(folder);
    ++out.read;
  }
  if (progress) progress(folders.size(), folders.size(), "");
  if (stop.load()) return Error{"scan interrupted: run it again to finish (what was read is kept)"};
  // The withdrawn are forgotten even when their folders are unchanged since the last scan.
  std::vector<std::string> kept;
  for (const auto& s : db.sessions())
    if (std::find(keep.begin(), keep.end(), s.folder) != keep.end() && !is_withdrawn(withdrawals, s.participant))
      kept.push_back(s.folder);
  auto removed = db.remove_except(kept);
  if (!removed) return removed.error();
  out.forgotten = removed.value();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return out;
}

}  // namespace pvcap::dataset
