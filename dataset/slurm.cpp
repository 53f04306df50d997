#include "dataset/slurm.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <sstream>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "core/subprocess.h"

namespace pvcap::dataset {

namespace fs = std::filesystem;

namespace {

// Runs argv[0] (found on PATH) and returns its standard output, or an Error with its exit status and
// what it printed.
Result<std::string> run(const std::vector<std::string>& args) {
  auto ran = run_program(args);
  if (!ran) return Error{fmt::format("{} (is Slurm installed, and {} on PATH?)", ran.error().message, args[0])};
  if (ran.value().exit_code != 0)
    return Error{fmt::format("{} failed (exit {}): {}", fmt::join(args, " "), ran.value().exit_code, ran.value().text)};
  return ran.value().text;
}

std::string quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

Status write_script(const fs::path& file, const std::string& text) {
  if (auto w = write_file_atomically(file, text, Durability::Synced); !w.ok()) return w;
  std::error_code ec;
  fs::permissions(file, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add, ec);
  return {};
}

std::string job_id(const std::string& sbatch_output) {
  std::string id = sbatch_output.substr(0, sbatch_output.find_first_of(";\n"));
  while (!id.empty() && std::isspace(static_cast<unsigned char>(id.back()))) id.pop_back();
  return id;
}

// `Key=value` from `scontrol show job -o` (one line of space-separated fields); empty when absent.
std::string job_field(const std::string& line, const std::string& key) {
  for (auto at = line.find(key + "="); at != std::string::npos; at = line.find(key + "=", at + 1)) {
    if (at != 0 && line[at - 1] != ' ') continue;  // `Key=` inside another field's value
    const auto from = at + key.size() + 1;
    return line.substr(from, line.find_first_of(" \n", from) - from);
  }
  return {};
}

// Follows a job until it ends, once a second: `sbatch --wait` polls after 2, 4, 8 and then every 10 s,
// so a release waited up to 10 s past its end. Ok when the job COMPLETED; otherwise an Error with its
// state and exit code, and where its log is.
Status wait_for_job(const std::string& id, const fs::path& logs) {
  int unreadable = 0;
  for (;;) {
    auto r = run({"scontrol", "show", "job", "-o", id});
    if (!r) {
      if (++unreadable >= 5) return Error{fmt::format("cannot follow Slurm job {}: {}", id, r.error().message)};
    } else {
      unreadable = 0;
      const std::string state = job_field(r.value(), "JobState");
      if (state == "COMPLETED") return {};
      static const char* const kEnded[] = {"FAILED",    "CANCELLED",     "TIMEOUT",  "NODE_FAIL",   "PREEMPTED",
                                           "BOOT_FAIL", "OUT_OF_MEMORY", "DEADLINE", "SPECIAL_EXIT"};
      for (const char* ended : kEnded)
        if (state == ended)
          return Error{fmt::format("Slurm job {} ended {} (exit code {}, reason {}); its log is in {}", id, state,
                                   job_field(r.value(), "ExitCode"), job_field(r.value(), "Reason"), logs.string())};
    }
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
}

}  // namespace

Result<SlurmSubmission> submit_to_slurm(const fs::path& pvcap, const fs::path& dataset_dir, const ReleasePlan& plan,
                                        bool wait) {
  const fs::path book = plan.book, logs = book / "slurm-logs";
  std::error_code ec;
  fs::create_directories(logs, ec);
  if (ec) return Error{fmt::format("{}: cannot be made: {}", logs.string(), ec.message())};
  const std::string common = fmt::format("{} --log-level warn dataset", quoted(pvcap.string()));
  const fs::path array_script = book / "release-job.sbatch", final_script = book / "release-finish.sbatch";
  if (auto w = write_script(
          array_script, fmt::format("#!/bin/sh\n# One session folder of the release (pvcap dataset release).\n"
                                    "#SBATCH --job-name=pvcap-release\n#SBATCH --output={}/%A_%a.log\n"
                                    "exec {} release-job {} --out {} --index \"$SLURM_ARRAY_TASK_ID\"\n",
                                    logs.string(), common, quoted(dataset_dir.string()), quoted(plan.out.string())));
      !w.ok())
    return w.error();
  if (auto w = write_script(
          final_script, fmt::format("#!/bin/sh\n# The release's manifest, datasheet and metadata, once every "
                                    "session is exported.\n#SBATCH --job-name=pvcap-release-finish\n"
                                    "#SBATCH --output={}/finish-%j.log\nexec {} release-finish {} --out {}\n",
                                    logs.string(), common, quoted(dataset_dir.string()), quoted(plan.out.string())));
      !w.ok())
    return w.error();
  SlurmSubmission s;
  const auto pending = pending_jobs(plan);
  s.tasks = pending.size();
  if (!pending.empty()) {
    std::string indices;
    for (auto i : pending) indices += (indices.empty() ? "" : ",") + std::to_string(i);
    auto r = run({"sbatch", "--parsable", "--array=" + indices, array_script.string()});
    if (!r) return r.error();
    s.array_job = job_id(r.value());
  }
  std::vector<std::string> args = {"sbatch", "--parsable"};
  if (!s.array_job.empty()) {
    args.push_back("--dependency=afterok:" + s.array_job);
    args.push_back("--kill-on-invalid-dep=yes");  // a failed task ends the final job, never leaves it waiting
  }
  args.push_back(final_script.string());
  auto r = run(args);
  if (!r) return r.error();
  s.final_job = job_id(r.value());
  if (wait)
    if (Status w = wait_for_job(s.final_job, logs); !w.ok()) return w.error();
  return s;
}

}  // namespace pvcap::dataset
