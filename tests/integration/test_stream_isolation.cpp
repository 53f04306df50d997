// A camera's stream receives that camera's frames and no other's. Aravis' packet-socket receiver
// (used when the process may open raw sockets: root, or CAP_NET_RAW) takes every packet on the
// interface from the moment its socket is made until its filter is attached; a stream made while
// another camera streams (a reconnection, a rig started camera by camera) could then assemble the
// other camera's frame as its own: a stored image under another camera's name. Seen as the
// reconnection test's rare "timecode does not match" (2026-11-26: cam0's frame in cam1's video).
// A stream takes frames only from right before AcquisitionStart, and not before it has settled.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>

#include "capture/aravis_camera.h"
#include "capture/aravis_handles.h"
#include "capture/aravis_stream.h"
#include "core/bounded_queue.h"
#include "core/rig_config.h"
#include "session_under_test.h"
#include "sim/netns.h"
#include "sim/sim_process.h"

namespace fs = std::filesystem;
using namespace pvcap;
using namespace std::chrono_literals;

TEST(StreamIsolation, AStreamMadeWhileAnotherCameraStreamsReceivesNoneOfItsFrames) {
  const std::vector<std::string> addresses{"127.0.0.2", "127.0.0.3"};
  if (!sim::addresses_present(addresses)) {
    ASSERT_TRUE(sim::enter_private_network(addresses).ok());
  }
  const fs::path work = pvcap::testing::work_dir("stream-isolation");
  std::ofstream(work / "rig.yaml") << pvcap::testing::sim_rig_yaml({{}, {}}, 320, 240, 100, 15);
  const RigConfig rig = load_rig_config(work / "rig.yaml");
  auto sim = sim::SimProcess::start(PVCAP_BIN, work / "rig.yaml", work / "truth", /*steerable=*/false);
  ASSERT_TRUE(sim) << sim.error().message;

  // cam0 streams (small frames at 100 Hz: a frame's packets go by in well under a millisecond).
  AravisCamera streaming(0, rig.cameras[0], nullptr);
  Status opened;
  for (int t = 0; t < 50 && !(opened = streaming.open()).ok(); ++t) std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  ASSERT_TRUE(streaming.start().ok());
  std::atomic<bool> done{false};
  std::thread drain([&] {
    while (!done.load()) (void)streaming.next_frame(20ms);
  });

  // cam1 never acquires: whatever its streams deliver is another camera's.
  arv::GPtr<ArvCamera> idle;
  for (int t = 0; t < 50 && !idle; ++t) {
    idle.reset(arv_camera_new(rig.cameras[1].address.c_str(), nullptr));
    if (!idle) std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(idle);
  arv_camera_set_region(idle.get(), 0, 0, 320, 240, nullptr);
  const auto payload = std::size_t(arv_camera_get_payload(idle.get(), nullptr));
  BoundedQueue<FrameLoss> losses(1000);
  std::size_t delivered = 0;
  std::string what;  // each delivered frame: its round, id, status and age of its stream
  for (int round = 0; round < 30; ++round) {
    const std::int64_t made_ns = host_now().ns;
    auto stream = AravisStream::create(idle.get(), 1, std::uint32_t(round), payload, 8, true, 0, losses);
    if (!stream) {
      ADD_FAILURE() << stream.error().message;
      break;
    }
    stream.value()->accept_from_now();  // as AravisCamera does right before AcquisitionStart
    std::this_thread::sleep_for(50ms);
    stream.value()->quiesce();
    while (auto f = stream.value()->take_frame(0ms)) {
      ++delivered;
      what += fmt::format("\n  round {}: frame id {}, {}, {:.0f} ms after its stream was made", round, f->frame_id,
                          f->status == FrameStatus::Good ? "complete" : "incomplete",
                          double(f->host_ts.ns - made_ns) / 1e6);
    }
  }
  done.store(true);
  drain.join();
  streaming.stop();
  std::printf("30 streams made while another camera streamed at 100 Hz: %zu frames delivered to them\n", delivered);
  EXPECT_EQ(delivered, 0u) << "a stream delivered frames of a camera that was not acquiring:" << what;
  sim.value().reset();  // stopped before its folder goes
}
