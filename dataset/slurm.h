#pragma once
// A release on a Slurm cluster: the prepared release's pending jobs as one job array (one task per
// session folder, each running `pvcap dataset release-job`), and a final job, dependent on every
// task of the array, that runs `pvcap dataset release-finish`. Resubmitting submits only what is
// not done. The batch scripts are written into the release's bookkeeping folder in the dataset
// (with the tasks' logs), so what ran can be read afterwards. sbatch (and scontrol, to wait) are found
// on PATH.
#include <filesystem>
#include <string>

#include "core/result.h"
#include "dataset/release.h"

namespace pvcap::dataset {

struct SlurmSubmission {
  std::string array_job;  // empty when no session was left to export
  std::string final_job;
  std::size_t tasks = 0;
};

// `pvcap` is this program's path (the tasks run it on the cluster's nodes: a shared file system is
// assumed, as for the sessions and the release folder). `wait`: follows the final job (scontrol,
// once a second), so this returns once the release is finished, or an Error when it failed.
Result<SlurmSubmission> submit_to_slurm(const std::filesystem::path& pvcap, const std::filesystem::path& dataset_dir,
                                        const ReleasePlan& plan, bool wait);

}  // namespace pvcap::dataset
