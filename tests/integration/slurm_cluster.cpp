#include "slurm_cluster.h"

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "session_under_test.h"

namespace fs = std::filesystem;

namespace pvcap::testing {

SlurmCluster::SlurmCluster(fs::path dir) : dir_(std::move(dir)) {}

SlurmCluster::~SlurmCluster() {
  for (pid_t p : pids_) kill(p, SIGTERM);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (pid_t p : pids_)
    while (kill(p, 0) == 0 && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
  for (pid_t p : pids_) kill(p, SIGKILL);
}

std::string SlurmCluster::prefix() const {
  return fmt::format("nsenter --net=/proc/{}/ns/net env SLURM_CONF={}", pids_.empty() ? 0 : pids_.front(),
                     (dir_ / "slurm.conf").string());
}

std::string SlurmCluster::start() {
  const fs::path d = fs::absolute(dir_);
  fs::create_directories(d / "state");
  fs::create_directories(d / "spool");
  fs::create_directories(d / "munge");
  fs::permissions(d / "munge", fs::perms::owner_all, fs::perm_options::replace);
  {
    std::random_device rd;
    std::ofstream key(d / "munge" / "munge.key", std::ios::binary);
    for (int i = 0; i < 128; ++i) key.put(char(rd() & 0xff));
  }
  fs::permissions(d / "munge" / "munge.key", fs::perms::owner_read, fs::perm_options::replace);
  std::ofstream(d / "slurm.conf") << fmt::format(
      "ClusterName=pvcaptest\nSlurmctldHost=localhost(127.0.0.1)\nSlurmUser=root\nSlurmdUser=root\n"
      "SlurmctldPort=6817\nSlurmdPort=6818\nAuthType=auth/munge\nAuthInfo=socket={0}/munge/munge.socket\n"
      "StateSaveLocation={0}/state\nSlurmdSpoolDir={0}/spool\nSlurmctldPidFile={0}/slurmctld.pid\n"
      "SlurmdPidFile={0}/slurmd.pid\nSlurmctldLogFile={0}/slurmctld.log\nSlurmdLogFile={0}/slurmd.log\n"
      "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSchedulerType=sched/builtin\n"
      "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\nReturnToService=2\nJobCompType=jobcomp/none\n"
      "AccountingStorageType=accounting_storage/none\nMpiDefault=none\n"
      "NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN\n"
      "PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP\n",
      d.string());
  // A namespace with loopback only, plus one non-loopback address on it: Slurm resolves its hosts
  // with AI_ADDRCONFIG, which finds no IPv4 where 127.0.0.1 is the only address.
  std::ofstream(d / "up.sh") << fmt::format(
      "set -e\nip link set lo up\nip addr add 10.254.0.1/32 dev lo\n"
      "munged --force --socket={0}/munge/munge.socket --key-file={0}/munge/munge.key "
      "--pid-file={0}/munge/munged.pid --log-file={0}/munge/munged.log --seed-file={0}/munge/seed\n"
      "slurmctld -f {0}/slurm.conf\nslurmd -f {0}/slurm.conf -N localhost\n",
      d.string());
  for (const char* tool : {"munged", "slurmctld", "slurmd", "sbatch", "nsenter", "unshare"})
    if (std::system(fmt::format("command -v {} > /dev/null", tool).c_str()) != 0)
      return fmt::format("{} is not installed (scripts/deps.sh --tests installs slurm-wlm and munge)", tool);
  const int rc =
      std::system(fmt::format("unshare -n sh {} > {} 2>&1", (d / "up.sh").string(), (d / "up.log").string()).c_str());
  auto pid_of = [&](const fs::path& file) -> pid_t {
    for (int i = 0; i < 100; ++i) {
      std::ifstream in(file);
      pid_t p = 0;
      if (in >> p && p > 0) return p;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return -1;
  };
  for (const fs::path& f : {d / "slurmctld.pid", d / "slurmd.pid", d / "munge" / "munged.pid"})
    if (pid_t p = pid_of(f); p > 0) pids_.push_back(p);
  auto logs = [&] {
    return fmt::format("\nup.sh:\n{}\nslurmctld.log:\n{}\nslurmd.log:\n{}\nmunged.log:\n{}", read_all(d / "up.log"),
                       read_all(d / "slurmctld.log"), read_all(d / "slurmd.log"), read_all(d / "munge" / "munged.log"));
  };
  if (rc != 0 || pids_.size() != 3) return "the cluster's daemons did not start" + logs();
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < end) {
    const auto r = std::system(fmt::format("{} sinfo -h -o %t 2>/dev/null | grep -q idle", prefix()).c_str());
    if (r == 0) return "";
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return "the cluster's node did not become idle within 30 s" + logs();
}

}  // namespace pvcap::testing
