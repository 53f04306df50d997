#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "capture/sensel_transport.h"

namespace pvcap::sensel {

namespace {

class TtyTransport : public Transport {
 public:
  TtyTransport(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  ~TtyTransport() override { ::close(fd_); }

  Status write(std::span<const std::uint8_t> bytes) override {
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
      if (n < 0) {
        if (errno == EINTR || errno == EAGAIN) {
          pollfd p{fd_, POLLOUT, 0};
          ::poll(&p, 1, 100);
          continue;
        }
        return Error{fmt::format("{}: write failed: {}", describe(), std::strerror(errno))};
      }
      done += std::size_t(n);
    }
    return {};
  }

  Result<std::size_t> read(std::span<std::uint8_t> into, int timeout_ms) override {
    pollfd p{fd_, POLLIN, 0};
    const int rc = ::poll(&p, 1, timeout_ms);
    if (rc < 0 && errno != EINTR) return Error{fmt::format("{}: {}", describe(), std::strerror(errno))};
    if (rc <= 0) return std::size_t{0};
    if (p.revents & (POLLHUP | POLLERR | POLLNVAL) && !(p.revents & POLLIN))
      return Error{fmt::format("{}: the device hung up (unplugged?)", describe())};
    const ssize_t n = ::read(fd_, into.data(), into.size());
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) return std::size_t{0};
      return Error{fmt::format("{}: {} (unplugged?)", describe(), std::strerror(errno))};
    }
    if (n == 0) return Error{fmt::format("{}: end of file (unplugged?)", describe())};
    return std::size_t(n);
  }

  std::string describe() const override { return "tty " + path_; }

 private:
  int fd_;
  std::string path_;
};

}  // namespace

Result<std::unique_ptr<Transport>> open_tty(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0)
    return Error{fmt::format("tty {}: cannot open: {}{}", path, std::strerror(errno),
                             errno == EACCES ? " (add the user to the dialout group or install a udev rule)" : "")};
  // One reader per Morph: a second pvcap (or `pvcap devices`) must not reconfigure or flush the
  // port of a session streaming from it. Taken before anything is written to the port.
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return Error{fmt::format("tty {}: in use by another pvcap (a running session reads this Morph)", path)};
  }
  termios t{};
  if (tcgetattr(fd, &t) != 0) {
    const int e = errno;
    ::close(fd);
    return Error{fmt::format("tty {}: not a terminal: {}", path, std::strerror(e))};
  }
  ioctl(fd, TIOCEXCL);  // and no other program's open (a terminal program, ModemManager) succeeds
  cfmakeraw(&t);
  cfsetispeed(&t, B115200);
  cfsetospeed(&t, B115200);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  tcsetattr(fd, TCSANOW, &t);
  tcflush(fd, TCIOFLUSH);
  return std::unique_ptr<Transport>(new TtyTransport(fd, path));
}

std::vector<std::string> sensel_tty_candidates(const std::filesystem::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    std::string name = e.path().filename().string();
    const bool acm = name.rfind("ttyACM", 0) == 0;
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (acm || name.find("morph") != std::string::npos) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace pvcap::sensel
