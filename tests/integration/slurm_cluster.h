#pragma once
// A one-node Slurm cluster on this machine for one test: munged, slurmctld and slurmd started as
// root inside a network namespace of their own (their ports are never on the machine's network),
// with their configuration, state, logs and munge key in a folder of the test's; stopped by their
// pids when the test ends. Needs Debian's slurm-wlm and munge (scripts/deps.sh --tests).
#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace pvcap::testing {

class SlurmCluster {
 public:
  explicit SlurmCluster(std::filesystem::path dir);
  ~SlurmCluster();  // stops every daemon it started
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  // Starts the daemons and waits until the node is idle; empty on success, else why not (with the
  // daemons' logs' last lines).
  std::string start();
  // A command prefix that runs a command in the cluster's namespace, with its SLURM_CONF.
  std::string prefix() const;

 private:
  std::filesystem::path dir_;
  std::vector<pid_t> pids_;
  pid_t netns_holder_ = -1;
};

}  // namespace pvcap::testing
