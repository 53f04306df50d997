// The camera watchdog (capture/camera_watchdog.h): when a camera is lost, fed the moments its control
// thread would see.
#include <gtest/gtest.h>

#include "capture/camera_watchdog.h"

using pvcap::CameraWatchdog;
using pvcap::HostNs;
using Verdict = CameraWatchdog::Verdict;
using namespace std::chrono_literals;

namespace {
HostNs ms(std::int64_t v) { return HostNs{v * 1'000'000}; }

CameraWatchdog free_running() {
  CameraWatchdog w({500ms, 3000ms, false, true});
  w.started(ms(1000));
  return w;
}
}  // namespace

TEST(CameraWatchdog, AFreeRunningCameraSilentPastItsStallTimeIsLost) {
  auto w = free_running();
  EXPECT_EQ(w.look(ms(1100), ms(1050), 0, false).verdict, Verdict::Fine);
  EXPECT_EQ(w.look(ms(1550), ms(1050), 0, false).verdict, Verdict::Fine);  // 500 ms: not yet
  const auto look = w.look(ms(1551), ms(1050), 0, false);
  EXPECT_EQ(look.verdict, Verdict::Lost);
  EXPECT_EQ(look.silent_ms, 501);
  EXPECT_EQ(look.why, "no frame for 501 ms");
}

TEST(CameraWatchdog, TheFirstFrameAfterAStartGetsTheLongerTimeout) {
  auto w = free_running();
  EXPECT_EQ(w.look(ms(3900), HostNs{0}, 0, false).verdict, Verdict::Fine);  // 2.9 s, no frame yet
  EXPECT_EQ(w.look(ms(4001), HostNs{0}, 0, false).verdict, Verdict::Lost);
  // A frame from before a restart does not count as this stream's first.
  w.started(ms(5000));
  EXPECT_EQ(w.look(ms(7000), ms(4500), 0, false).verdict, Verdict::Fine);
}

TEST(CameraWatchdog, UnderrunsShowACameraStillSendingWhilePvcapHoldsEveryBuffer) {
  auto w = free_running();
  EXPECT_EQ(w.look(ms(1400), ms(1100), 3, false).verdict, Verdict::Fine);  // underruns at 1400 ms
  EXPECT_EQ(w.look(ms(1800), ms(1100), 3, false).verdict, Verdict::Fine);  // 400 ms since them
  EXPECT_EQ(w.look(ms(1901), ms(1100), 3, false).verdict, Verdict::Lost);  // no new underrun since 1400
}

TEST(CameraWatchdog, AControlChannelLostIsLostAtOnce) {
  auto w = free_running();
  const auto look = w.look(ms(1100), ms(1090), 0, true);
  EXPECT_EQ(look.verdict, Verdict::Lost);
  EXPECT_EQ(look.why, "control channel lost");
}

TEST(CameraWatchdog, ACameraOnATriggerLineIsAskedAndLostAfterThreeUnansweredAsks) {
  CameraWatchdog w({500ms, 3000ms, true, true});
  w.started(ms(0));
  EXPECT_EQ(w.look(ms(400), ms(100), 0, false).verdict, Verdict::Fine);
  auto look = w.look(ms(700), ms(100), 0, false);  // silent past the stall time: ask
  ASSERT_EQ(look.verdict, Verdict::Ask);
  EXPECT_FALSE(w.answered(false));
  EXPECT_EQ(w.look(ms(750), ms(100), 0, false).verdict, Verdict::Fine);  // asks 250 ms apart
  ASSERT_EQ(w.look(ms(950), ms(100), 0, false).verdict, Verdict::Ask);
  EXPECT_FALSE(w.answered(false));
  ASSERT_EQ(w.look(ms(1200), ms(100), 0, false).verdict, Verdict::Ask);
  EXPECT_FALSE(w.answered(false));
  look = w.look(ms(1250), ms(100), 0, false);
  EXPECT_EQ(look.verdict, Verdict::Lost);
  EXPECT_EQ(look.why, "no frame for 1150 ms, and no answer when asked");
}

TEST(CameraWatchdog, ACameraOnATriggerLineThatAnswersIsNotLostAndItsMissingTriggerIsSaidOnce) {
  CameraWatchdog w({500ms, 3000ms, true, true});
  w.started(ms(0));
  for (std::int64_t t = 700; t < 5000; t += 250) {
    const auto look = w.look(ms(t), ms(100), 0, false);
    ASSERT_NE(look.verdict, Verdict::Lost) << t;
    if (look.verdict == Verdict::Ask) {
      EXPECT_EQ(w.answered(true), t == 700) << "said once, at the first ask: " << t;
    }
  }
  // Frames again, then silence again: said again.
  EXPECT_EQ(w.look(ms(5100), ms(5090), 0, false).verdict, Verdict::Fine);
  ASSERT_EQ(w.look(ms(5700), ms(5090), 0, false).verdict, Verdict::Ask);
  EXPECT_TRUE(w.answered(true));
}

TEST(CameraWatchdog, ACameraOnATriggerLineThatCannotBeAskedIsLostOnlyByItsControlChannel) {
  CameraWatchdog w({500ms, 3000ms, true, false});
  w.started(ms(0));
  EXPECT_EQ(w.look(ms(60'000), ms(100), 0, false).verdict, Verdict::Fine);
  EXPECT_EQ(w.look(ms(60'050), ms(100), 0, true).verdict, Verdict::Lost);
}
