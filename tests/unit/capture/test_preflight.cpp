#include <gtest/gtest.h>

#include "capture/aravis_camera.h"

using pvcap::LinkBudget;
using pvcap::preflight;

TEST(Preflight, Full1080p60BayerOnGigabitIsRefusedWithAWayOut) {
  // 1920x1080 x 1 byte x 60 fps = 995 Mbit/s of pixels, over 1 Gbit/s with protocol overhead.
  const auto s = preflight("cam0", LinkBudget{1920 * 1080, 60.0, 1000, 0, 4 << 20});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("cam0"), std::string::npos);
  EXPECT_NE(s.error().message.find("lower frame_rate"), std::string::npos) << s.error().message;
}

TEST(Preflight, SameStreamOnTenGigabitPasses) {
  EXPECT_TRUE(preflight("cam0", LinkBudget{1920 * 1080, 60.0, 10000, 0, 4 << 20}).ok());
}

TEST(Preflight, SocketBufferAboveKernelLimitNamesTheSysctl) {
  const auto s = preflight("cam1", LinkBudget{640 * 480, 30.0, 1000, 64 << 20, 4 << 20});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("net.core.rmem_max"), std::string::npos) << s.error().message;
}

TEST(Preflight, BufferPoolCoversHalfASecond) {
  pvcap::CameraConfig c;
  c.frame_rate = 60;
  EXPECT_EQ(pvcap::buffer_count_for(c), 30u);
  c.frame_rate = 5;
  EXPECT_EQ(pvcap::buffer_count_for(c), 8u);
  c.buffer_count = 100;
  EXPECT_EQ(pvcap::buffer_count_for(c), 100u);
}

// Cameras on one link must fit it together: each alone fits, four together do not.
TEST(Preflight, CamerasSharingALinkMustFitItTogether) {
  EXPECT_TRUE(preflight("cam0", LinkBudget{1920 * 1080, 30.0, 1000, 0, 4 << 20}).ok()) << "one alone fits";
  const auto s = preflight("cam0", LinkBudget{1920 * 1080, 30.0, 1000, 0, 4 << 20, 4, "nic0"});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("4 cameras share link 'nic0' (1000 Mbit/s)"), std::string::npos)
      << s.error().message;
  EXPECT_TRUE(preflight("cam0", LinkBudget{640 * 480, 60.0, 1000, 0, 4 << 20, 4, "nic0"}).ok());
}

// Each camera on a shared link is paced to its share: its packets leave a gap of (n - 1) packets'
// wire time, so n cameras' bursts together take the link's rate and no more.
TEST(Preflight, ASharedLinksPacingLeavesEachCameraItsShare) {
  const pvcap::LinkPacing four = pvcap::link_pacing(8192, 1000, 4);
  EXPECT_DOUBLE_EQ(four.share_bytes_per_s, 1e9 / 8 / 4);
  EXPECT_NEAR(four.packet_delay_s, 8192.0 * 8 * 3 / 1e9, 1e-12);  // 196.6 us
  const pvcap::LinkPacing alone = pvcap::link_pacing(8192, 1000, 1);
  EXPECT_DOUBLE_EQ(alone.packet_delay_s, 0.0);
  EXPECT_DOUBLE_EQ(alone.share_bytes_per_s, 1e9 / 8);
}
