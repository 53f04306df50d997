#include "sim/sensel_pty.h"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdlib.h>
#include <sys/prctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include <fmt/format.h>

#include "codec/sensel_protocol.h"
#include "core/time.h"

namespace pvcap::sim {

Result<std::unique_ptr<SenselPty>> SenselPty::create(SenselEmulator& emulator, SenselLink link) {
  std::unique_ptr<SenselPty> p(new SenselPty(emulator, link));
  p->master_ = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (p->master_ < 0 || grantpt(p->master_) != 0 || unlockpt(p->master_) != 0)
    return Error{fmt::format("cannot create a pseudo-terminal: {}", std::strerror(errno))};
  termios t{};
  tcgetattr(p->master_, &t);
  cfmakeraw(&t);
  tcsetattr(p->master_, TCSANOW, &t);
  p->slave_path_ = ptsname(p->master_);
  p->thread_ = std::thread([raw = p.get()] { raw->serve(); });
  return p;
}

SenselPty::~SenselPty() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
  if (master_ >= 0) ::close(master_);
}

void SenselPty::unplug() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
  ::close(master_);  // the slave side now reads EOF/EIO, as after a USB unplug
  master_ = -1;
}

void SenselPty::serve() {
  // Answers leave when the pacer says, not up to 50 us later (the kernel's default timer slack):
  // the emulated device's latency floor is then the pseudo-terminal's alone.
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  // A Morph answers on its own silicon, whatever the host's load: the emulator's thread takes a
  // real-time priority where allowed (and a replay's timing is what it re-serves). What it cannot
  // lift is the pseudo-terminal's kernel worker, at a normal priority: on saturated cores it can
  // still hold the answers back for 65-100 ms (docs/testing.md, "How the suite is scheduled").
  {
    sched_param rt{};
    rt.sched_priority = 10;
    (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt);
  }

  std::uint8_t buf[256];
  SenselPacer pacer(emu_, link_);
  auto send = [&](const std::vector<std::uint8_t>& out) {
    std::size_t done = 0;
    // Answers go out in 64-byte pieces, like USB full-speed bulk packets.
    while (done < out.size() && running_.load()) {
      const ssize_t w = ::write(master_, out.data() + done, std::min<std::size_t>(64, out.size() - done));
      if (w > 0) {
        done += std::size_t(w);
      } else if (errno == EAGAIN) {
        // The pseudo-terminal is full until the recorder reads: waited for, not spun (a spin at
        // a real-time priority holds a core the recorder that must drain it may be waiting for).
        pollfd writable{master_, POLLOUT, 0};
        (void)::poll(&writable, 1, 5);
      } else if (errno != EINTR) {
        break;
      }
    }
  };
  while (running_.load()) {
    pollfd p{master_, POLLIN, 0};
    const int ready = ::poll(&p, 1, emu_.reg(sensel::reg::kScanEnabled) == 2 ? 2 : 50);
    send(emu_.async_frames_due(host_now().ns));  // async scanning pushes frames unasked
    if (ready <= 0 || !(p.revents & POLLIN)) continue;
    const ssize_t n = ::read(master_, buf, sizeof buf);
    const std::int64_t asked_ns = host_now().ns;
    if (n <= 0) continue;
    if (const int stall = stall_ms_.exchange(0); stall > 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(stall));
      continue;  // the request is lost, as on a hung device
    }
    const auto answer = pacer.answer(std::span<const std::uint8_t>(buf, std::size_t(n)), asked_ns);
    if (const std::int64_t wait_ns = answer.deliver_at_ns - host_now().ns; wait_ns > 0)
      std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
    const std::int64_t woke_ns = host_now().ns;
    send(answer.bytes);
    if (answer.replayed) emu_.replay_sent(asked_ns, woke_ns, host_now().ns);
  }
}

}  // namespace pvcap::sim
