#include "headless_browser.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <optional>

#include <fmt/format.h>

namespace pvcap::testing {

namespace {

std::string base64_decode(const std::string& in) {
  static const std::string chars = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  int val = 0, bits = -8;
  for (char c : in) {
    const auto pos = chars.find(c);
    if (pos == std::string::npos) break;
    val = (val << 6) + int(pos);
    bits += 6;
    if (bits >= 0) {
      out.push_back(char((val >> bits) & 0xFF));
      bits -= 8;
    }
  }
  return out;
}

}  // namespace

HeadlessBrowser::HeadlessBrowser(int width, int height) {
  if (std::system("command -v chromium > /dev/null") != 0) return;
  static int instances = 0;
  profile_ = std::filesystem::temp_directory_path() / fmt::format("pvcap-chromium-{}-{}", getpid(), ++instances);
  std::filesystem::remove_all(profile_);
  int in[2], out[2];  // in: test -> browser (its fd 3); out: browser -> test (its fd 4)
  if (pipe(in) != 0 || pipe(out) != 0) return;
  pid_ = fork();
  if (pid_ == 0) {
    dup2(in[0], 3);
    dup2(out[1], 4);
    for (int fd : {in[0], in[1], out[0], out[1]})
      if (fd > 4) close(fd);
    const int devnull = ::open("/dev/null", O_WRONLY);
    dup2(devnull, 1);
    dup2(devnull, 2);
    const std::string profile = "--user-data-dir=" + profile_.string();
    const std::string size = fmt::format("--window-size={},{}", width, height);
    execlp("chromium", "chromium", "--headless", "--no-sandbox", "--disable-gpu", "--remote-debugging-pipe",
           "--no-first-run", "--hide-scrollbars", profile.c_str(), size.c_str(), "about:blank",
           static_cast<char*>(nullptr));
    _exit(127);
  }
  close(in[0]);
  close(out[1]);
  to_browser_ = in[1];
  from_browser_ = out[0];
}

HeadlessBrowser::~HeadlessBrowser() {
  if (pid_ > 0) {
    send({{"id", next_id_++}, {"method", "Browser.close"}});
    for (int i = 0; i < 50; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        break;
      }
      usleep(100000);
    }
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  if (to_browser_ >= 0) close(to_browser_);
  if (from_browser_ >= 0) close(from_browser_);
  std::error_code ec;
  if (!profile_.empty()) std::filesystem::remove_all(profile_, ec);
}

bool HeadlessBrowser::send(const nlohmann::json& message) {
  const std::string text = message.dump() + '\0';
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = write(to_browser_, text.data() + done, text.size() - done);
    if (n <= 0) return false;
    done += std::size_t(n);
  }
  return true;
}

std::optional<nlohmann::json> HeadlessBrowser::receive(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (const auto nul = buffer_.find('\0'); nul != std::string::npos) {
      auto message = nlohmann::json::parse(buffer_.substr(0, nul), nullptr, false);
      buffer_.erase(0, nul + 1);
      return message;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    pollfd p{from_browser_, POLLIN, 0};
    if (poll(&p, 1, int(left.count())) <= 0) continue;
    char chunk[65536];
    const ssize_t n = read(from_browser_, chunk, sizeof chunk);
    if (n <= 0) return std::nullopt;
    buffer_.append(chunk, std::size_t(n));
  }
}

nlohmann::json HeadlessBrowser::call(const std::string& method, const nlohmann::json& params,
                                     const std::string& session) {
  if (!ok()) return nullptr;
  const int id = next_id_++;
  nlohmann::json m = {{"id", id}, {"method", method}, {"params", params}};
  if (!session.empty()) m["sessionId"] = session;
  if (!send(m)) {
    failed_ = true;
    return nullptr;
  }
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < end) {
    auto reply = receive(std::chrono::seconds(30));
    if (!reply) break;
    if (!reply->is_object()) continue;
    // Console errors and exceptions of the pages, kept for the test to check.
    const std::string event = reply->value("method", "");
    if (event == "Runtime.exceptionThrown") errors_.push_back((*reply)["params"]["exceptionDetails"].dump());
    if (event == "Runtime.consoleAPICalled" && (*reply)["params"].value("type", "") == "error")
      errors_.push_back((*reply)["params"]["args"].dump());
    if (reply->value("id", -1) == id) return reply->contains("result") ? (*reply)["result"] : nlohmann::json();
  }
  failed_ = true;
  return nullptr;
}

std::string HeadlessBrowser::open(const std::string& url) {
  // Each page in a window of its own: a background tab gets no animation frames, and the pages
  // rightly count only what is on a screen.
  const auto target = call("Target.createTarget", {{"url", "about:blank"}, {"newWindow", true}});
  if (!target.is_object() || !target.contains("targetId")) return {};
  const auto attached = call("Target.attachToTarget", {{"targetId", target["targetId"]}, {"flatten", true}});
  if (!attached.is_object() || !attached.contains("sessionId")) return {};
  const std::string tab = attached["sessionId"];
  call("Runtime.enable", nlohmann::json::object(), tab);
  call("Page.enable", nlohmann::json::object(), tab);
  call("Page.navigate", {{"url", url}}, tab);
  return tab;
}

nlohmann::json HeadlessBrowser::eval(const std::string& tab, const std::string& expression) {
  const auto r = call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}}, tab);
  if (!r.is_object() || !r.contains("result") || !r["result"].contains("value")) return nullptr;
  return r["result"]["value"];
}

bool HeadlessBrowser::screenshot(const std::string& tab, const std::filesystem::path& png) {
  const auto r = call("Page.captureScreenshot", {{"format", "png"}}, tab);
  if (!r.is_object() || !r.contains("data")) return false;
  std::filesystem::create_directories(png.parent_path());
  std::ofstream(png, std::ios::binary) << base64_decode(r["data"].get<std::string>());
  return std::filesystem::file_size(png) > 0;
}

}  // namespace pvcap::testing
