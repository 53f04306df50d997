#include "dataset/release.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <thread>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "core/time.h"
#include "core/version.h"
#include "export/dataset_export.h"
#include "export/sha256.h"
#include "storage/tools/compact.h"

namespace pvcap::dataset {

namespace fs = std::filesystem;
using json = nlohmann::json;

fs::path bookkeeping(const fs::path& dataset_dir, const fs::path& out) {
  std::string path = fs::absolute(out).lexically_normal().string();
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  std::string name = path;
  for (char& ch : name)
    if (ch == '/') ch = '_';
  // The path's own hash beside it: /a/b_c and /a_b/c must not share one plan and its done markers.
  return dataset_dir / "releases" / (name + "-" + exporting::sha256_hex(path).substr(0, 8));
}

namespace {

fs::path done_marker(const ReleasePlan& plan, std::size_t i) { return plan.book / "done" / std::to_string(i); }

std::string utc_date() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  return fmt::format("{:04}-{:02}-{:02}", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday);
}

// A released sequence, read back from the release's folders.
struct ReleasedSequence {
  std::string participant_folder, name, action, hand, session;
  std::size_t frames = 0;
};

std::vector<ReleasedSequence> released_sequences(const fs::path& out, const std::string& meta_name) {
  static const std::regex name_rx(R"(^(.+)_(\d+)x_(left|right)(\(\d+\))?$)");
  std::vector<ReleasedSequence> list;
  std::error_code ec;
  for (fs::directory_iterator p(out, ec), end; !ec && p != end; p.increment(ec)) {
    if (!p->is_directory() || p->path().filename().string().rfind('.', 0) == 0) continue;
    std::error_code inner;
    for (fs::directory_iterator q(p->path(), inner), qend; !inner && q != qend; q.increment(inner)) {
      if (!fs::exists(q->path() / meta_name)) continue;  // not (yet) complete
      ReleasedSequence s;
      s.participant_folder = p->path().filename().string();
      s.name = q->path().filename().string();
      std::smatch m;
      if (std::regex_match(s.name, m, name_rx)) {
        s.action = m[1];
        s.hand = m[3];
      }
      std::ifstream src(q->path() / "pvcap_source.json");
      const json source = json::parse(src, nullptr, false);
      if (source.is_object() && source.contains("session") && source["session"].is_string())
        s.session = source["session"].get<std::string>();
      std::error_code ec2;
      for (fs::directory_iterator f(q->path() / "force", ec2), fend; !ec2 && f != fend; f.increment(ec2)) ++s.frames;
      list.push_back(std::move(s));
    }
  }
  std::sort(list.begin(), list.end(), [](auto& a, auto& b) {
    return std::tie(a.participant_folder, a.name) < std::tie(b.participant_folder, b.name);
  });
  return list;
}

std::string table_row(const std::vector<std::string>& cells) {
  return "| " + fmt::format("{}", fmt::join(cells, " | ")) + " |\n";
}

std::string datasheet(const DatasetConfig& c, const ReleasePlan& plan, const DatasetStatus& status,
                      const Splits& splits, const std::vector<CatalogSession>& sessions,
                      const std::vector<ReleasedSequence>& seqs, const std::string& protocol_sha) {
  std::map<std::string, const CatalogSession*> by_folder;
  for (const auto& s : sessions) by_folder[s.folder] = &s;
  std::string md =
      fmt::format("# {}\n\n{}\n\n", c.name, c.description.empty() ? "(no description given)" : c.description);
  md += fmt::format(
      "Released with pvcap {} in the {} layout (../shared/specs/pressurevision-dataset.md): one folder per "
      "participant, one per sequence; `SHA256SUMS` checks every file (`sha256sum -c SHA256SUMS`), "
      "`croissant.json` describes the release in Croissant 1.0, `splits.json` holds the participant-held-out "
      "splits.\n\n",
      kVersion, plan.layout);
  md += fmt::format("License: {}. URL: {}. Creators: {}.\n\n", c.license, c.url, fmt::join(c.creators, ", "));
  // Counts per participant.
  std::map<std::string, std::pair<std::size_t, std::size_t>> per_participant, per_action, per_condition;
  for (const auto& s : seqs) {
    auto& p = per_participant[s.participant_folder];
    ++p.first;
    p.second += s.frames;
    auto& a = per_action[s.action + " (" + s.hand + ")"];
    ++a.first;
    a.second += s.frames;
    const auto* session = by_folder.count(s.session) ? by_folder[s.session] : nullptr;
    auto& k = per_condition[session ? session->lighting + ", " + session->overlay : "unknown"];
    ++k.first;
    k.second += s.frames;
  }
  std::size_t frames = 0;
  for (const auto& s : seqs) frames += s.frames;
  md += fmt::format(
      "## Contents\n\n{} participants, {} session folders, {} sequences, {} frames (15 Hz samples, each "
      "with every camera's image and the pressure).\n\n",
      per_participant.size(), plan.sessions.size(), seqs.size(), frames);
  auto counts = [&](const std::string& title, const std::string& key,
                    const std::map<std::string, std::pair<std::size_t, std::size_t>>& m) {
    md += fmt::format("### Per {}\n\n", title) + table_row({key, "sequences", "frames"}) + "|---|---|---|\n";
    for (const auto& [k, v] : m) md += table_row({k, std::to_string(v.first), std::to_string(v.second)});
    md += "\n";
  };
  counts("participant", "participant folder", per_participant);
  counts("condition", "lighting, sensor overlay", per_condition);
  counts("action", "action (hand)", per_action);
  md += fmt::format(
      "## Protocol\n\n`{}` ({} action rows, each with the left and the right hand; SHA-256 of the file "
      "{}).\n\n",
      c.protocol.filename().string(), status.actions.size(), protocol_sha);
  md += "## Calibration and synchronisation, per session\n\n" +
        table_row({"session", "participant", "verify", "cameras pad-calibrated", "sync self-check offsets (ms)"}) +
        "|---|---|---|---|---|\n";
  for (const auto& folder : plan.sessions) {
    if (!by_folder.count(folder)) continue;
    const CatalogSession& s = *by_folder[folder];
    json facts = json::parse(s.facts_json, nullptr, false);
    if (!facts.is_object()) facts = json::object();
    int calibrated = 0, cameras = 0;
    std::vector<std::string> offsets;
    for (const auto& cam : facts.value("calibration", json::array())) {
      ++cameras;
      calibrated += cam.value("pad_calibrated", false);
    }
    for (const auto& cam : facts.value("self_check", json::array()))
      offsets.push_back(cam.contains("offset_ms") && cam["offset_ms"].is_number()
                            ? fmt::format("{:+.2f}", cam["offset_ms"].get<double>())
                            : "n/a");
    md += table_row({fs::path(folder).filename().string(), s.participant,
                     s.verify_exit == 0   ? "clean"
                     : s.verify_exit == 3 ? "lossy"
                                          : "failed",
                     fmt::format("{} of {}", calibrated, cameras), fmt::format("{}", fmt::join(offsets, ", "))});
  }
  md +=
      fmt::format("\n## Splits (held out by participant, seed {})\n\ntrain: {}\n\nval: {}\n\ntest: {}\n\n", splits.seed,
                  fmt::join(splits.train, ", "), fmt::join(splits.val, ", "), fmt::join(splits.test, ", "));
  md += "## Known issues (pvcap's QA flags at release)\n\n";
  std::set<std::string> released(plan.participants.begin(), plan.participants.end());
  std::size_t n = 0;
  for (const auto& f : status.flags) {
    if (!released.count(f.participant)) continue;
    md += fmt::format("- {} {}{}: {}\n", f.participant, f.kind,
                      f.folder.empty() ? "" : " (" + fs::path(f.folder).filename().string() + ")", f.message);
    ++n;
  }
  if (n == 0) md += "None.\n";
  for (const auto& p : status.participants)
    if (released.count(p.code) && !p.remaining.empty())
      md += fmt::format("- {} incomplete: {} of the protocol's takes not recorded\n", p.code, p.remaining.size());
  if (status.withdrawn)
    md +=
        fmt::format("\n{} participant(s) withdrew consent; none of their data is in this release.\n", status.withdrawn);
  return md;
}

// The sequence folders of every done take, per participant in the order of their sessions (the
// plan's order: participant, then start).
std::map<std::string, std::map<std::string, std::string>> name_sequence_folders(
    const std::vector<std::string>& planned, const std::vector<CatalogSession>& sessions,
    const std::vector<CatalogTake>& takes) {
  std::map<std::string, std::string> participant_of;
  for (const auto& s : sessions) participant_of[s.folder] = s.participant;
  std::map<std::string, std::set<std::string>> used;  // participant -> folder names given
  std::map<std::string, std::map<std::string, std::string>> out;
  for (const auto& folder : planned) {
    auto& taken = used[participant_of[folder]];
    for (const auto& t : takes) {
      if (t.folder != folder || t.status != "done") continue;
      std::string name = t.sequence;
      for (int n = 2; taken.count(name); ++n) name = fmt::format("{}({})", t.sequence, n);
      taken.insert(name);
      out[folder][fmt::format("{}:{}", t.step, t.start_ns.value_or(0))] = name;
    }
  }
  return out;
}

}  // namespace

Result<ReleasePlan> prepare_release(const fs::path& dataset_dir, const std::vector<CatalogSession>& sessions,
                                    const std::vector<CatalogTake>& takes, const std::vector<Withdrawal>& withdrawals,
                                    const fs::path& out_given, const std::string& layout, bool compact) {
  ReleasePlan plan;
  plan.out = fs::absolute(out_given).lexically_normal();
  plan.book = bookkeeping(dataset_dir, plan.out);
  plan.layout = layout;
  plan.compact = compact;
  std::set<std::string> codes;
  for (const auto& s : sessions) {
    if (is_withdrawn(withdrawals, s.participant)) continue;
    plan.sessions.push_back(s.folder);
    codes.insert(s.participant);
  }
  plan.participants.assign(codes.begin(), codes.end());
  plan.sequence_folders = name_sequence_folders(plan.sessions, sessions, takes);
  if (plan.sessions.empty())
    return Error{"the catalogue holds no session to release (run `pvcap dataset status` to scan)"};
  std::error_code ec;
  fs::create_directories(plan.book / "done", ec);
  if (!ec) fs::create_directories(plan.out, ec);
  if (ec) return Error{fmt::format("{}: cannot be made: {}", plan.out.string(), ec.message())};
  const fs::path plan_file = plan.book / "plan.json";
  json j = {{"layout", plan.layout},
            {"sessions", plan.sessions},
            {"participants", plan.participants},
            {"sequence_folders", plan.sequence_folders}};
  if (plan.compact) j["compact"] = true;  // absent otherwise: an earlier plan compares equal
  if (fs::exists(plan_file)) {
    const json before = read_json_file(plan_file, json::object());
    if (before != j)
      return Error{fmt::format(
          "{}: holds a release of other sessions, another layout or another --compact; release into an empty "
          "folder (or remove it)",
          plan.out.string())};
  } else if (auto w = write_file_atomically(plan_file, j.dump(2) + "\n", Durability::Synced); !w.ok()) {
    return w.error();
  }
  // Participant folders fixed by code order before any job runs (the export takes these).
  json map = read_json_file(plan.out / "participants.json", json::object());
  int next = 1;
  for (const auto& [code, folder] : map.items())
    if (folder.is_string()) next = std::max(next, std::atoi(folder.get<std::string>().substr(0, 4).c_str()) + 1);
  for (const auto& code : plan.participants)
    if (!map.contains(code)) map[code] = fmt::format("{:04d}_{}", next++, code);
  if (auto w = write_file_atomically(plan.out / "participants.json", map.dump(2) + "\n", Durability::Synced); !w.ok())
    return w.error();
  return plan;
}

Result<ReleasePlan> load_plan(const fs::path& dataset_dir, const fs::path& out_given) {
  ReleasePlan plan;
  plan.out = fs::absolute(out_given).lexically_normal();
  plan.book = bookkeeping(dataset_dir, plan.out);
  const json j = read_json_file(plan.book / "plan.json", nullptr);
  if (!j.is_object())
    return Error{fmt::format("{}: no release into it was prepared by this dataset (no {})", plan.out.string(),
                             (plan.book / "plan.json").string())};
  const RecordReader r(j, plan.book / "plan.json");
  plan.layout = r.text("layout");
  plan.sessions = r.texts("sessions");
  plan.participants = r.texts("participants");
  plan.compact = j.contains("compact") && j["compact"].is_boolean() && j["compact"].get<bool>();
  if (j.contains("sequence_folders") && j["sequence_folders"].is_object())
    for (const auto& [session, names] : j["sequence_folders"].items()) {
      const RecordReader n(names, plan.book / "plan.json");
      for (const auto& [key, value] : names.items()) plan.sequence_folders[session][key] = n.text(key.c_str());
    }
  return plan;
}

bool job_done(const ReleasePlan& plan, std::size_t i) { return fs::exists(done_marker(plan, i)); }

std::vector<std::size_t> pending_jobs(const ReleasePlan& plan) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < plan.sessions.size(); ++i)
    if (!job_done(plan, i)) out.push_back(i);
  return out;
}

Status run_release_job(const ReleasePlan& plan, std::size_t i, const std::atomic<bool>& stop) {
  if (i >= plan.sessions.size())
    return Error{fmt::format("job {} is not in the release's plan ({} sessions)", i, plan.sessions.size())};
  if (job_done(plan, i)) return {};
  if (plan.compact) {
    CompactOptions c;
    c.stop = &stop;
    auto done = compact_session(plan.sessions[i], c);
    if (!done) return done.error();
    if (done.value().stopped)
      return Error{
          fmt::format("{}: interrupted while compacting; run the release again to finish it", plan.sessions[i])};
  }
  exporting::ExportOptions o;
  o.out = plan.out;
  if (const auto names = plan.sequence_folders.find(plan.sessions[i]); names != plan.sequence_folders.end())
    o.sequence_folders = names->second;
  o.layout =
      plan.layout == "pressurevision-plus" ? exporting::Layout::PressureVisionPlus : exporting::Layout::PressureVision;
  auto r = exporting::export_session(plan.sessions[i], o, stop);
  if (!r) {
    // A session with no takes (it ran no protocol) has nothing to release: done, with nothing.
    if (r.error().message.find("ran no protocol") == std::string::npos) return r.error();
  } else if (r.value().interrupted) {
    return Error{fmt::format("{}: interrupted; run the release again to finish it", plan.sessions[i])};
  }
  return write_file_atomically(done_marker(plan, i), plan.sessions[i] + "\n", Durability::Synced);
}

Status run_local(const ReleasePlan& plan, int workers,
                 const std::function<void(std::size_t, std::size_t, const std::string&)>& progress,
                 const std::atomic<bool>& stop) {
  const auto pending = pending_jobs(plan);
  std::mutex m;
  std::size_t next = 0, done = plan.sessions.size() - pending.size();
  std::vector<std::string> failures;
  if (progress) progress(done, plan.sessions.size(), "");
  auto worker = [&] {
    for (;;) {
      std::size_t i;
      {
        std::lock_guard lock(m);
        if (next >= pending.size() || stop.load()) return;
        i = pending[next++];
      }
      const Status s = run_release_job(plan, i, stop);
      std::lock_guard lock(m);
      if (!s.ok()) failures.push_back(s.error().message);
      ++done;
      if (progress) progress(done, plan.sessions.size(), fs::path(plan.sessions[i]).filename().string());
    }
  };
  std::vector<std::thread> threads;
  for (int w = 0; w < std::max(1, workers); ++w) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (!failures.empty())
    return Error{fmt::format("{} of {} sessions failed to export:\n  {}", failures.size(), plan.sessions.size(),
                             fmt::join(failures, "\n  "))};
  if (stop.load()) return Error{"release interrupted: run the same command again to finish it"};
  return {};
}

Result<std::size_t> write_sha256sums(const fs::path& out) {
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(out, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path rel = it->path().lexically_relative(out);
    if (it->is_regular_file() && rel != "SHA256SUMS") files.push_back(rel.string());
  }
  if (ec) return Error{fmt::format("{}: cannot be listed: {}", out.string(), ec.message())};
  std::sort(files.begin(), files.end());
  std::string sums;
  for (const auto& f : files) {
    auto h = exporting::sha256_file(out / f);
    if (!h) return h.error();
    sums += h.value() + "  " + f + "\n";
  }
  if (auto w = write_file_atomically(out / "SHA256SUMS", sums, Durability::Synced); !w.ok()) return w.error();
  return files.size();
}

json croissant_metadata(const DatasetConfig& c, const ReleasePlan& plan, const std::string& date,
                        const std::string& readme_sha256, const std::string& splits_sha256) {
  const bool plus = plan.layout == "pressurevision-plus";
  const std::string meta = plus ? "meta.json" : "metadata.json";
  json creators = json::array();
  for (const auto& name : c.creators) creators.push_back({{"@type", "sc:Person"}, {"name", name}});
  auto file_set = [](const std::string& id, const std::string& format, const std::string& includes,
                     const std::string& what) {
    return json{{"@type", "cr:FileSet"},    {"@id", id},           {"name", id}, {"description", what},
                {"encodingFormat", format}, {"includes", includes}};
  };
  auto from_path = [](const std::string& id, const std::string& regex, const std::string& what) {
    return json{{"@type", "cr:Field"},
                {"@id", "sequences/" + id},
                {"name", id},
                {"description", what},
                {"dataType", "sc:Text"},
                {"source",
                 {{"fileSet", {{"@id", "sequence-metadata"}}},
                  {"extract", {{"fileProperty", "filepath"}}},
                  {"transform", {{"regex", regex}}}}}};
  };
  return {{"@context",
           {{"@language", "en"},
            {"@vocab", "https://schema.org/"},
            {"sc", "https://schema.org/"},
            {"cr", "http://mlcommons.org/croissant/"},
            {"dct", "http://purl.org/dc/terms/"},
            {"conformsTo", "dct:conformsTo"},
            {"data", {{"@id", "cr:data"}, {"@type", "@json"}}},
            {"dataType", {{"@id", "cr:dataType"}, {"@type", "@vocab"}}},
            {"extract", "cr:extract"},
            {"field", "cr:field"},
            {"fileProperty", "cr:fileProperty"},
            {"fileObject", "cr:fileObject"},
            {"fileSet", "cr:fileSet"},
            {"includes", "cr:includes"},
            {"key", "cr:key"},
            {"recordSet", "cr:recordSet"},
            {"regex", "cr:regex"},
            {"source", "cr:source"},
            {"transform", "cr:transform"}}},
          {"@type", "sc:Dataset"},
          {"name", c.name},
          {"description", c.description.empty() ? c.name : c.description},
          {"conformsTo", "http://mlcommons.org/croissant/1.0"},
          {"license", c.license},
          {"url", c.url},
          {"creator", creators},
          {"datePublished", date},
          {"version", "1.0.0"},
          {"keywords", {"hand pressure", "tactile", "multi-view video", "PressureVision"}},
          {"distribution",
           {{{"@type", "cr:FileObject"},
             {"@id", "README.md"},
             {"name", "README.md"},
             {"contentUrl", "README.md"},
             {"encodingFormat", "text/markdown"},
             {"sha256", readme_sha256}},
            {{"@type", "cr:FileObject"},
             {"@id", "splits.json"},
             {"name", "splits.json"},
             {"contentUrl", "splits.json"},
             {"encodingFormat", "application/json"},
             {"sha256", splits_sha256}},
            file_set("sequence-metadata", "application/json", "*/*/" + meta,
                     "each sequence's metadata: cameras, calibration, lighting"),
            file_set("camera-images", "image/jpeg", "*/*/camera_*/*.jpg", "each camera's frame of each 15 Hz sample"),
            file_set("pressure", "application/octet-stream", "*/*/force/*",
                     "the pressure of each sample, 105 x 185 float32 in the loaders' counts (counts / 2.7125 = kPa)")}},
          {"recordSet",
           {{{"@type", "cr:RecordSet"},
             {"@id", "sequences"},
             {"name", "sequences"},
             {"description", "one record per released sequence (a take of one action with one hand)"},
             {"key", {{"@id", "sequences/path"}}},
             {"field",
              {from_path("path", "^(.*)/[^/]+$", "the sequence's folder"),
               from_path("participant", "^([^/]+)/.*$", "the participant's folder (<id>_<pseudonymous code>)"),
               from_path("sequence", "^[^/]+/([^/]+)/.*$", "the sequence's name: <action>_<repetitions>x_<hand>")}}}}}};
}

Status check_release_metadata(const DatasetConfig& c) {
  std::vector<std::string> missing;
  if (c.license.empty()) missing.push_back("license");
  if (c.url.empty()) missing.push_back("url");
  if (c.creators.empty()) missing.push_back("creators");
  if (missing.empty()) return {};
  return Error{fmt::format(
      "{}: set {} before a release (its Croissant metadata requires license, url and creators); nothing was "
      "exported",
      (c.dir / "dataset.yaml").string(), fmt::join(missing, ", "))};
}

Result<ReleaseSummary> finish_release(const DatasetConfig& c, const ReleasePlan& plan, const DatasetStatus& status,
                                      const Splits& splits, const std::vector<CatalogSession>& sessions) {
  if (Status s = check_release_metadata(c); !s.ok()) return s.error();
  const auto pending = pending_jobs(plan);
  if (!pending.empty()) {
    std::vector<std::string> names;
    for (auto i : pending) names.push_back(fs::path(plan.sessions[i]).filename().string());
    return Error{fmt::format("{} of {} sessions are not exported yet ({}); run the release again", pending.size(),
                             plan.sessions.size(), fmt::join(names, ", "))};
  }
  // Only the released participants' splits.
  Splits released_splits = splits;
  const std::set<std::string> released(plan.participants.begin(), plan.participants.end());
  for (auto* v : {&released_splits.train, &released_splits.val, &released_splits.test})
    v->erase(std::remove_if(v->begin(), v->end(), [&](const std::string& code) { return !released.count(code); }),
             v->end());
  const std::string splits_text = json{{"held_out_by", "participant"},
                                       {"seed", released_splits.seed},
                                       {"train", released_splits.train},
                                       {"val", released_splits.val},
                                       {"test", released_splits.test}}
                                      .dump(2) +
                                  "\n";
  if (auto w = write_file_atomically(plan.out / "splits.json", splits_text, Durability::Synced); !w.ok())
    return w.error();
  const auto seqs = released_sequences(plan.out, plan.layout == "pressurevision-plus" ? "meta.json" : "metadata.json");
  auto protocol_sha = exporting::sha256_file(c.protocol);
  const std::string readme =
      datasheet(c, plan, status, released_splits, sessions, seqs, protocol_sha ? protocol_sha.value() : "unreadable");
  if (auto w = write_file_atomically(plan.out / "README.md", readme, Durability::Synced); !w.ok()) return w.error();
  const json croissant =
      croissant_metadata(c, plan, utc_date(), exporting::sha256_hex(readme), exporting::sha256_hex(splits_text));
  if (auto w = write_file_atomically(plan.out / "croissant.json", croissant.dump(2) + "\n", Durability::Synced);
      !w.ok())
    return w.error();
  auto files = write_sha256sums(plan.out);
  if (!files) return files.error();
  ReleaseSummary sum;
  sum.files = files.value();
  sum.sequences = seqs.size();
  for (const auto& s : seqs) sum.frames += s.frames;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(plan.out, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file()) sum.bytes += it->file_size();
  if (auto r = record_release(c.dir, {plan.out.string(), wall_now_ns(), plan.participants}); !r.ok()) return r.error();
  return sum;
}

}  // namespace pvcap::dataset
