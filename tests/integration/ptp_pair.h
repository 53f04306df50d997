#pragma once
// Two PTP hosts on this machine for one test: two network namespaces of the test's own, joined by a
// veth pair, each with a real linuxptp ptp4l on its end (software timestamping, `free_running 1`:
// ptp4l measures and never adjusts the clock, which the namespaces share with this machine; never
// phc2sys). The first is the grandmaster (priority1 1), the second follows it (slaveOnly). Their
// management sockets are files in the test's folder, which pvcap's pmc reaches from any namespace.
// Every process is stopped by its pid when the pair ends. Needs Debian's linuxptp and iproute2.
#include <sys/types.h>

#include <filesystem>
#include <string>

namespace pvcap::testing {

class PtpPair {
 public:
  explicit PtpPair(std::filesystem::path dir);
  ~PtpPair();  // stops both ptp4l and both namespaces' holders; removes the veth pair
  PtpPair(const PtpPair&) = delete;
  PtpPair& operator=(const PtpPair&) = delete;

  // Makes the namespaces and the link, starts both ptp4l; empty on success, else why not.
  std::string start();
  // The follower's ptp4l stopped (a host whose ptp4l died), or started again.
  void stop_follower();
  std::string restart_follower();

  std::filesystem::path grandmaster_socket() const { return dir_ / "gm.sock"; }
  std::filesystem::path follower_socket() const { return dir_ / "follower.sock"; }
  std::filesystem::path follower_log() const { return dir_ / "follower.log"; }

 private:
  std::string start_ptp4l(int side);
  std::filesystem::path dir_;
  pid_t holders_[2] = {-1, -1};
  pid_t ptp4l_[2] = {-1, -1};
  std::string link_[2];
};

}  // namespace pvcap::testing
