// `pvcap dataset`: init, status, split, release (and the release's job and finish steps, which a
// Slurm job array runs), withdraw. Wiring only: the work is dataset/'s.
#include <chrono>
#include <random>
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "app/command.h"
#include "console/progress_line.h"
#include "core/durable_folder.h"
#include "core/time.h"
#include "dataset/dataset_state.h"
#include "dataset/release.h"
#include "dataset/slurm.h"
#include "dataset/status_files.h"

namespace pvcap {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

struct DatasetArgs {
  fs::path dir;
  dataset::DatasetConfig init;
  std::string protocol;
  std::vector<std::string> roots;
  bool json_out = false;
  int test = 0, val = 0;
  std::int64_t seed = -1;
  fs::path out;
  std::string layout = "pressurevision", scheduler = "local";
  int jobs = 2;
  bool wait = false, compact = false;
  std::size_t index = 0;
  std::string participant, reason;
  bool purge = false;
};

// The dataset, its catalogue brought up to date first when `rescan` (progress on stderr).
dataset::DatasetState load(const fs::path& dir, bool rescan, const std::atomic<bool>& stop) {
  if (!rescan) return dataset::open_dataset(dir, nullptr, stop);
  console::ProgressLine bar;
  const dataset::ScanProgress progress =
      bar.counter("scan", "session folders", [](const std::string& f) { return ": " + f; });
  return dataset::open_dataset(dir, &progress, stop);
}

int run_init(DatasetArgs& a) {
  auto& c = a.init;
  c.dir = fs::absolute(a.dir).lexically_normal();
  c.protocol = fs::absolute(a.protocol).lexically_normal();
  protocol::load_protocol(c.protocol);  // a bad protocol is said now, not at the first status
  for (const auto& r : a.roots) c.session_roots.push_back(fs::absolute(r).lexically_normal());
  if (c.name.empty()) c.name = c.dir.filename().string();
  if (auto w = dataset::write_dataset(c); !w.ok()) throw UserError(w.error().message);
  fmt::print("{}: dataset '{}' over {} session root(s); `pvcap dataset status {}` catalogues it\n",
             (c.dir / "dataset.yaml").string(), c.name, c.session_roots.size(), a.dir.string());
  if (c.license.empty() || c.url.empty() || c.creators.empty())
    fmt::print("  set license, url and creators in dataset.yaml before a release (its metadata requires them)\n");
  return 0;
}

int run_status(const DatasetArgs& a, const std::atomic<bool>& stop) {
  const dataset::DatasetState l = load(a.dir, true, stop);
  const auto leaks = dataset::split_leakage(l);
  const json j = dataset::write_status_files(l.config, l.protocol, l.status, leaks);
  if (a.json_out) {
    json out = j;
    out["leakage"] = leaks;
    fmt::print("{}\n", out.dump(2));
    return 0;
  }
  fmt::print("{}", dataset::format_status(l.status));
  for (const auto& p : leaks) fmt::print("splits: {}\n", p);
  for (const auto& p : l.status.participants)
    if (!p.remaining.empty())
      fmt::print("{}: {} takes to record: {}\n", p.code, p.remaining.size(),
                 (l.config.dir / "remaining" / (p.code + ".yaml")).string());
  fmt::print("page: {}\n", (l.config.dir / "dataset.html").string());
  return 0;
}

int run_split(const DatasetArgs& a, const std::atomic<bool>& stop) {
  const dataset::DatasetState l = load(a.dir, true, stop);
  const auto candidates = dataset::split_candidates(l);
  const std::uint64_t seed = a.seed >= 0 ? std::uint64_t(a.seed) : std::random_device{}();
  const auto s = dataset::make_splits(candidates, a.test, a.val, seed);
  if (auto w = dataset::save_splits(l.config.dir, s, candidates); !w.ok()) throw UserError(w.error().message);
  fmt::print("splits (seed {}; --seed {} makes them again):\n  train: {}\n  val:   {}\n  test:  {}\n", seed, seed,
             fmt::join(s.train, " "), fmt::join(s.val, " "), fmt::join(s.test, " "));
  const auto leaks = dataset::leakage_problems(s, l.sessions, l.withdrawals);
  for (const auto& p : leaks) fmt::print("leak: {}\n", p);
  return leaks.empty() ? 0 : 1;
}

// The release's last step, from the catalogue as the release was prepared.
int finish(const fs::path& dir, const fs::path& out, const std::atomic<bool>& stop) {
  const auto started = std::chrono::steady_clock::now();
  const dataset::DatasetState l = load(dir, false, stop);
  auto plan = dataset::load_plan(l.config.dir, out);
  if (!plan) throw UserError(plan.error().message);
  const auto splits = dataset::load_splits(l.config.dir);
  if (!splits)
    throw UserError(fmt::format("{}: missing; a release needs its splits", (l.config.dir / "splits.json").string()));
  auto r = dataset::finish_release(l.config, plan.value(), l.status, *splits, l.sessions);
  if (!r) throw UserError(r.error().message);
  fmt::print(
      "{}: {} sequences, {} frames, {} files ({:.1f} MB); finished in {:.1f} s; check with: cd {} && sha256sum -c "
      "SHA256SUMS\n",
      plan.value().out.string(), r.value().sequences, r.value().frames, r.value().files, double(r.value().bytes) / 1e6,
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(), plan.value().out.string());
  return 0;
}

int run_release(const DatasetArgs& a, const AppContext& ctx) {
  // What the release needs from its inputs is checked before the work: the metadata first (hours of
  // export, then a refusal, would be the worst order), then the splits and their leakage.
  if (Status s = dataset::check_release_metadata(dataset::load_dataset(a.dir)); !s.ok())
    throw UserError(s.error().message);
  const dataset::DatasetState l = load(a.dir, true, ctx.stop);
  if (!dataset::load_splits(l.config.dir))
    throw UserError(fmt::format("{}: no splits yet; make them first (pvcap dataset split {} --test N --val N)",
                                (l.config.dir / "splits.json").string(), a.dir.string()));
  if (const auto leaks = dataset::split_leakage(l); !leaks.empty())
    throw UserError(fmt::format("the splits leak, so no release:\n  {}", fmt::join(leaks, "\n  ")));
  auto plan = dataset::prepare_release(l.config.dir, l.sessions, l.takes, l.withdrawals, a.out, a.layout, a.compact);
  if (!plan) throw UserError(plan.error().message);
  const auto& p = plan.value();
  fmt::print("release of {} session folders ({} participants) into {}; {} to {}export\n", p.sessions.size(),
             p.participants.size(), p.out.string(), dataset::pending_jobs(p).size(), p.compact ? "compact and " : "");
  if (a.scheduler == "slurm") {
    auto s = dataset::submit_to_slurm(ctx.self_exe, l.config.dir, p, a.wait);
    if (!s) throw UserError(s.error().message);
    fmt::print("submitted to Slurm: {} task(s){}, final job {}{}\n", s.value().tasks,
               s.value().array_job.empty() ? "" : " in job array " + s.value().array_job, s.value().final_job,
               a.wait ? " (finished)" : "; logs in " + (p.book / "slurm-logs").string());
    return 0;
  }
  console::ProgressLine bar;
  const Status s = dataset::run_local(
      p, a.jobs, bar.counter("release", "sessions exported", [](const std::string& f) { return " (last: " + f + ")"; }),
      ctx.stop);
  if (!s.ok()) {
    bar.abandon();
    throw UserError(s.error().message);
  }
  return finish(a.dir, a.out, ctx.stop);
}

int run_release_job(const DatasetArgs& a, const std::atomic<bool>& stop) {
  auto plan = dataset::load_plan(dataset::load_dataset(a.dir).dir, a.out);
  if (!plan) throw UserError(plan.error().message);
  const auto started = std::chrono::steady_clock::now();
  if (auto s = dataset::run_release_job(plan.value(), a.index, stop); !s.ok()) throw UserError(s.error().message);
  fmt::print("job {}: {} exported in {:.1f} s\n", a.index, plan.value().sessions.at(a.index),
             std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  return 0;
}

int run_withdraw(const DatasetArgs& a, const std::atomic<bool>& stop) {
  const dataset::DatasetState l = load(a.dir, true, stop);
  std::vector<std::string> participants;
  for (const auto& p : l.status.participants) participants.push_back(p.code);
  dataset::WithdrawRequest request{a.participant, a.reason, a.purge, wall_now_ns()};
  auto done = dataset::withdraw(l.config, participants, l.sessions, request);
  if (!done) throw UserError(done.error().message);
  const dataset::WithdrawReport& r = done.value();
  load(a.dir, true, stop);  // the scan forgets the withdrawn participant's folders
  fmt::print("{} withdrawn ({}): out of the catalogue ({} session folders), the splits and every later release\n",
             a.participant, a.reason, r.session_folders.size());
  for (const auto& release : r.releases) {
    fmt::print("  release {} holds them{}\n", release.out,
               release.folder.empty() ? "" : " in " + (fs::path(release.out) / release.folder).string());
    if (release.removed)
      fmt::print("    removed; its SHA256SUMS rewritten (make a new release for an up-to-date datasheet)\n");
  }
  if (r.sessions_removed)
    for (const auto& f : r.session_folders) fmt::print("  session {} removed\n", f);
  else if (!r.session_folders.empty())
    fmt::print("  their session folders stay on disk (--purge removes them and their released folders)\n");
  return 0;
}

}  // namespace

Registered add_dataset_command(CLI::App& app, AppContext& ctx) {
  auto a = std::make_shared<DatasetArgs>();
  auto* d = app.add_subcommand("dataset",
                               "many sessions as one dataset: catalogue, completeness, splits, releases, "
                               "withdrawals (docs/dataset.md)");
  d->require_subcommand(1);
  auto* init = d->add_subcommand("init", "make a dataset folder (writes its dataset.yaml)");
  init->add_option("DIR", a->dir, "the dataset folder")->required();
  init->add_option("--protocol", a->protocol, "the protocol its sessions run")->required()->check(CLI::ExistingFile);
  init->add_option("--sessions", a->roots, "folders holding its session folders")->required();
  init->add_option("--name", a->init.name, "the dataset's name (default: the folder's)");
  init->add_option("--description", a->init.description, "one paragraph on what it is");
  init->add_option("--license", a->init.license, "licence URL (e.g. https://creativecommons.org/licenses/by-nc/4.0/)");
  init->add_option("--url", a->init.url, "where the dataset will be published");
  init->add_option("--creator", a->init.creators, "a creator's name (repeat for several)");
  init->add_option("--participants", a->init.planned_participants, "the planned participants' codes");
  init->add_option("--conditions", a->init.conditions, "the planned lighting conditions (e.g. LCR L-R)");

  auto* status = d->add_subcommand("status", "catalogue the sessions; completeness, QA flags, what remains");
  status->add_option("DIR", a->dir, "the dataset folder")->required()->check(CLI::ExistingDirectory);
  status->add_flag("--json", a->json_out, "print the status as JSON");

  auto* split = d->add_subcommand("split", "participant-held-out splits into DIR/splits.json");
  split->add_option("DIR", a->dir, "the dataset folder")->required()->check(CLI::ExistingDirectory);
  split->add_option("--test", a->test, "participants held out for testing")->required()->check(CLI::NonNegativeNumber);
  split->add_option("--val", a->val, "participants held out for validation")->required()->check(CLI::NonNegativeNumber);
  split->add_option("--seed", a->seed, "the random seed (printed; the same seed, the same splits)");

  auto* release = d->add_subcommand("release", "export every session, with splits, datasheet, metadata, SHA256SUMS");
  release->add_option("DIR", a->dir, "the dataset folder")->required()->check(CLI::ExistingDirectory);
  release->add_option("--out", a->out, "the release folder")->required();
  release->add_option("--layout", a->layout, "pressurevision or pressurevision-plus")
      ->check(CLI::IsMember({"pressurevision", "pressurevision-plus"}));
  release->add_option("--scheduler", a->scheduler, "local (a process pool here, the default) or slurm")
      ->check(CLI::IsMember({"local", "slurm"}));
  release->add_option("--jobs", a->jobs, "local: sessions exported at once (default 2)")->check(CLI::Range(1, 64));
  release->add_flag("--wait", a->wait, "slurm: return once the release is finished");
  release->add_flag("--compact", a->compact,
                    "each session's job first compacts its raw video (pvcap compact: denser, bit-exact)");

  auto* job = d->add_subcommand("release-job", "one session of a prepared release (a Slurm array task runs it)");
  job->add_option("DIR", a->dir, "the dataset folder")->required();
  job->add_option("--out", a->out, "the release folder")->required();
  job->add_option("--index", a->index, "the session's index in the release's plan")->required();
  auto* fin = d->add_subcommand("release-finish", "a release's manifest, datasheet and metadata, once all is exported");
  fin->add_option("DIR", a->dir, "the dataset folder")->required();
  fin->add_option("--out", a->out, "the release folder")->required();

  auto* withdraw = d->add_subcommand("withdraw", "a participant withdraws consent");
  withdraw->add_option("DIR", a->dir, "the dataset folder")->required()->check(CLI::ExistingDirectory);
  withdraw->add_option("PARTICIPANT", a->participant, "the participant's code")->required();
  withdraw->add_option("--reason", a->reason, "why (recorded; no personal data)")->required();
  withdraw->add_flag("--purge", a->purge, "also remove their session folders and their folders in past releases");

  return {d, [=, &ctx]() -> int {
            if (*init) return run_init(*a);
            if (*status) return run_status(*a, ctx.stop);
            if (*split) return run_split(*a, ctx.stop);
            if (*release) return run_release(*a, ctx);
            if (*job) return run_release_job(*a, ctx.stop);
            if (*fin) return finish(a->dir, a->out, ctx.stop);
            if (*withdraw) return run_withdraw(*a, ctx.stop);
            return 2;
          }};
}

}  // namespace pvcap
