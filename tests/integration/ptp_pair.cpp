#include "tests/integration/ptp_pair.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <thread>
#include <vector>

#include <fmt/format.h>

extern "C" char** environ;

namespace pvcap::testing {

namespace fs = std::filesystem;

namespace {

// Starts args in the background, its output into `log`; its pid (-1 when it could not start).
pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, args[0].c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

void stop(pid_t& pid) {
  if (pid <= 0) return;
  kill(pid, SIGTERM);
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0 && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  if (waitpid(pid, &status, WNOHANG) == 0) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  pid = -1;
}

std::string netns_of(pid_t pid) {
  std::error_code ec;
  const fs::path link = fs::read_symlink(fmt::format("/proc/{}/ns/net", pid), ec);
  return ec ? std::string() : link.string();
}

}  // namespace

PtpPair::PtpPair(fs::path dir) : dir_(std::move(dir)) {
  fs::create_directories(dir_);
  // Names unique on this machine while the pair lives (15 characters at most).
  link_[0] = fmt::format("pvp{}g", getpid() % 1000000);
  link_[1] = fmt::format("pvp{}f", getpid() % 1000000);
}

PtpPair::~PtpPair() {
  for (pid_t& p : ptp4l_) stop(p);
  for (pid_t& p : holders_) stop(p);  // the namespace goes with its last process, and the veth pair with it
}

std::string PtpPair::start() {
  for (const char* tool : {"ptp4l", "pmc", "unshare", "nsenter", "ip"})
    if (std::system(fmt::format("command -v {} > /dev/null", tool).c_str()) != 0)
      return fmt::format("{} is not installed (scripts/deps.sh --tests installs linuxptp and iproute2)", tool);
  const std::string own = netns_of(getpid());
  for (int side = 0; side < 2; ++side) {
    holders_[side] = spawn({"unshare", "-n", "sleep", "86400"}, dir_ / "holders.log");
    if (holders_[side] < 0) return "cannot start unshare";
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (netns_of(holders_[side]) == own && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (netns_of(holders_[side]) == own) return "unshare -n made no network namespace";
  }
  const fs::path up = dir_ / "link.sh";
  {
    std::ofstream s(up);
    s << "set -e\n"
      << fmt::format("ip link add {} type veth peer name {}\n", link_[0], link_[1]);
    for (int side = 0; side < 2; ++side) {
      const std::string in = fmt::format("nsenter --net=/proc/{}/ns/net", holders_[side]);
      s << fmt::format("ip link set {} netns {}\n", link_[side], holders_[side])
        << fmt::format("{} ip addr add 10.77.0.{}/24 dev {}\n", in, side + 1, link_[side])
        << fmt::format("{} ip link set {} up\n{} ip link set lo up\n", in, link_[side], in);
    }
  }
  if (std::system(fmt::format("sh {} > {} 2>&1", up.string(), (dir_ / "link.log").string()).c_str()) != 0) {
    std::ifstream log(dir_ / "link.log");
    return "the veth link could not be made: " + std::string(std::istreambuf_iterator<char>(log), {});
  }
  for (int side = 0; side < 2; ++side)
    if (std::string why = start_ptp4l(side); !why.empty()) return why;
  return {};
}

std::string PtpPair::start_ptp4l(int side) {
  const bool gm = side == 0;
  const fs::path cfg = dir_ / (gm ? "gm.cfg" : "follower.cfg");
  {
    std::ofstream c(cfg);
    // Measures only, and quickly: announces four times a second, a master chosen within a second.
    c << "[global]\nfree_running 1\ntime_stamping software\n"
      << (gm ? "priority1 1\n" : "priority1 200\nslaveOnly 1\n")
      << "logAnnounceInterval -2\nannounceReceiptTimeout 2\nlogSyncInterval -3\nlogMinDelayReqInterval -3\n"
      << "uds_address " << (gm ? grandmaster_socket() : follower_socket()).string() << "\n";
  }
  ptp4l_[side] = spawn({"nsenter", fmt::format("--net=/proc/{}/ns/net", holders_[side]), "ptp4l", "-f", cfg.string(),
                        "-i", link_[side], "-m"},
                       gm ? dir_ / "gm.log" : follower_log());
  return ptp4l_[side] < 0 ? "cannot start ptp4l" : std::string();
}

void PtpPair::stop_follower() { stop(ptp4l_[1]); }

std::string PtpPair::restart_follower() {
  stop(ptp4l_[1]);
  return start_ptp4l(1);
}

}  // namespace pvcap::testing
