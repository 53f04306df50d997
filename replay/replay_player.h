#pragma once
// The replay window's state without the window (replay_window.h draws it): which sample is shown,
// playing or paused, at what speed, moved by the keys and by time. Playback follows the session's
// one clock: while playing, the sample shown is the last one whose session time the playback clock
// has reached (session time = where play started + wall time since then x speed), never the order
// in which frames arrived.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pvcap::replay {

enum class PlayerKey {
  None,
  PlayPause,     // space
  StepForward,   // right arrow, '.'  (pauses)
  StepBack,      // left arrow, ','   (pauses)
  SeekForward,   // ']', page down: +5 s of session time
  SeekBack,      // '[', page up: -5 s
  NextTake,      // 'n'
  PreviousTake,  // 'p'
  Faster,        // '+', '=', up arrow: speed x 2 (up to 8)
  Slower,        // '-', down arrow: speed / 2 (down to 1/8)
  Start,         // home
  End,           // end
  Quit,          // 'q', escape
};
// From what cv::waitKeyEx returns (its Qt and GTK backends code arrows differently), or a key's
// name for scripted keys ("space", "right", "left", "up", "down", "pgup", "pgdn", "home", "end",
// "esc", or a single character).
PlayerKey key_from_code(int code);
PlayerKey key_from_name(const std::string& name);
// The help line the window shows.
const char* key_help();

class ReplayPlayer {
 public:
  // `sample_ns`: each sample's session time, in sample order (increasing); `take_starts`: the first
  // sample of each take, increasing.
  ReplayPlayer(std::vector<std::int64_t> sample_ns, std::vector<std::size_t> take_starts);

  void press(PlayerKey key, std::int64_t now_ns);
  // While playing: moves to the sample the playback clock has reached at `now_ns` (wall clock);
  // at the last sample it pauses.
  void tick(std::int64_t now_ns);

  std::size_t position() const { return position_; }
  std::size_t size() const { return sample_ns_.size(); }
  bool playing() const { return playing_; }
  double speed() const { return speed_; }
  bool quit() const { return quit_; }
  // How long the window may wait for a key before the next sample is due (ms, >= 1); paused: long.
  int wait_ms(std::int64_t now_ns) const;

 private:
  void go_to(std::size_t i);
  void restart_clock(std::int64_t now_ns);  // playback continues from the shown sample
  std::size_t sample_at_or_before(std::int64_t t_ns) const;
  std::vector<std::int64_t> sample_ns_;
  std::vector<std::size_t> take_starts_;
  std::size_t position_ = 0;
  bool playing_ = false, quit_ = false;
  double speed_ = 1.0;
  std::int64_t clock_wall_ns_ = 0, clock_session_ns_ = 0;  // the playback clock's reference
};

}  // namespace pvcap::replay
