#include "replay/replay_player.h"

#include <algorithm>
#include <cmath>

namespace pvcap::replay {

namespace {
constexpr std::int64_t kSeekNs = 5'000'000'000;
constexpr double kMinSpeed = 0.125, kMaxSpeed = 8.0;
}  // namespace

PlayerKey key_from_code(int code) {
  switch (code) {
    case ' ':
      return PlayerKey::PlayPause;
    case '.':
    case '>':
      return PlayerKey::StepForward;
    case ',':
    case '<':
      return PlayerKey::StepBack;
    case ']':
      return PlayerKey::SeekForward;
    case '[':
      return PlayerKey::SeekBack;
    case 'n':
    case 'N':
      return PlayerKey::NextTake;
    case 'p':
    case 'P':
      return PlayerKey::PreviousTake;
    case '+':
    case '=':
      return PlayerKey::Faster;
    case '-':
    case '_':
      return PlayerKey::Slower;
    case 'q':
    case 'Q':
    case 27:
      return PlayerKey::Quit;
    // GTK (X11 keysyms) and Qt (Qt::Key) codes of the special keys.
    case 0xFF53:
    case 0x01000014:
      return PlayerKey::StepForward;  // right
    case 0xFF51:
    case 0x01000012:
      return PlayerKey::StepBack;  // left
    case 0xFF52:
    case 0x01000013:
      return PlayerKey::Faster;  // up
    case 0xFF54:
    case 0x01000015:
      return PlayerKey::Slower;  // down
    case 0xFF56:
    case 0x01000017:
      return PlayerKey::SeekForward;  // page down
    case 0xFF55:
    case 0x01000016:
      return PlayerKey::SeekBack;  // page up
    case 0xFF50:
    case 0x01000010:
      return PlayerKey::Start;  // home
    case 0xFF57:
    case 0x01000011:
      return PlayerKey::End;  // end
    case 0x01000000:
      return PlayerKey::Quit;  // Qt's escape
    default:
      return PlayerKey::None;
  }
}

PlayerKey key_from_name(const std::string& name) {
  if (name == "space") return PlayerKey::PlayPause;
  if (name == "right") return PlayerKey::StepForward;
  if (name == "left") return PlayerKey::StepBack;
  if (name == "up") return PlayerKey::Faster;
  if (name == "down") return PlayerKey::Slower;
  if (name == "pgdn") return PlayerKey::SeekForward;
  if (name == "pgup") return PlayerKey::SeekBack;
  if (name == "home") return PlayerKey::Start;
  if (name == "end") return PlayerKey::End;
  if (name == "esc") return PlayerKey::Quit;
  if (name.size() == 1) return key_from_code(static_cast<unsigned char>(name[0]));
  return PlayerKey::None;
}

const char* key_help() { return "space play/pause   <- -> step   [ ] 5 s   p n take   - + speed   home end   q quit"; }

ReplayPlayer::ReplayPlayer(std::vector<std::int64_t> sample_ns, std::vector<std::size_t> take_starts)
    : sample_ns_(std::move(sample_ns)), take_starts_(std::move(take_starts)) {}

std::size_t ReplayPlayer::sample_at_or_before(std::int64_t t_ns) const {
  const auto it = std::upper_bound(sample_ns_.begin(), sample_ns_.end(), t_ns);
  return it == sample_ns_.begin() ? 0 : std::size_t(it - sample_ns_.begin()) - 1;
}

void ReplayPlayer::go_to(std::size_t i) {
  if (sample_ns_.empty()) return;
  position_ = std::min(i, sample_ns_.size() - 1);
}

void ReplayPlayer::restart_clock(std::int64_t now_ns) {
  clock_wall_ns_ = now_ns;
  clock_session_ns_ = sample_ns_.empty() ? 0 : sample_ns_[position_];
}

void ReplayPlayer::press(PlayerKey key, std::int64_t now_ns) {
  if (sample_ns_.empty()) {
    quit_ = quit_ || key == PlayerKey::Quit;
    return;
  }
  const std::size_t last = sample_ns_.size() - 1;
  switch (key) {
    case PlayerKey::None:
      return;
    case PlayerKey::PlayPause:
      playing_ = !playing_;
      if (playing_ && position_ == last) go_to(0);  // play again from the start
      break;
    case PlayerKey::StepForward:
      playing_ = false;
      go_to(position_ + 1);
      break;
    case PlayerKey::StepBack:
      playing_ = false;
      go_to(position_ == 0 ? 0 : position_ - 1);
      break;
    case PlayerKey::SeekForward:
      go_to(sample_at_or_before(sample_ns_[position_] + kSeekNs));
      break;
    case PlayerKey::SeekBack:
      go_to(sample_at_or_before(sample_ns_[position_] - kSeekNs));
      break;
    case PlayerKey::NextTake: {
      const auto it = std::upper_bound(take_starts_.begin(), take_starts_.end(), position_);
      if (it != take_starts_.end()) go_to(*it);
      break;
    }
    case PlayerKey::PreviousTake: {
      // The start of the take before the one shown (the last to start at or before it); the
      // first take's own start when there is none before it.
      auto it = std::upper_bound(take_starts_.begin(), take_starts_.end(), position_);
      if (it == take_starts_.begin()) break;  // before every take
      --it;
      if (it != take_starts_.begin()) --it;
      go_to(*it);
      break;
    }
    case PlayerKey::Faster:
      speed_ = std::min(kMaxSpeed, speed_ * 2);
      break;
    case PlayerKey::Slower:
      speed_ = std::max(kMinSpeed, speed_ / 2);
      break;
    case PlayerKey::Start:
      go_to(0);
      break;
    case PlayerKey::End:
      playing_ = false;
      go_to(last);
      break;
    case PlayerKey::Quit:
      quit_ = true;
      break;
  }
  restart_clock(now_ns);
}

void ReplayPlayer::tick(std::int64_t now_ns) {
  if (!playing_ || sample_ns_.empty()) return;
  const auto t = clock_session_ns_ + std::int64_t(std::llround(double(now_ns - clock_wall_ns_) * speed_));
  go_to(sample_at_or_before(t));
  if (position_ == sample_ns_.size() - 1) playing_ = false;  // the end: stop there
}

int ReplayPlayer::wait_ms(std::int64_t now_ns) const {
  if (!playing_ || position_ + 1 >= sample_ns_.size()) return 50;  // keys only (and window events)
  const auto next_session = sample_ns_[position_ + 1];
  const double wall_left = double(next_session - clock_session_ns_) / speed_ - double(now_ns - clock_wall_ns_);
  return std::max(1, int(std::ceil(wall_left / 1e6)));
}

}  // namespace pvcap::replay
