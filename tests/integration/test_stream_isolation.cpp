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
#include "codec/pixel_format.h"
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

// The runtime guard behind the settling: a stream that receives another camera's packet flow (here
// cam0 told to send to cam1's stream port, which cam1's stream takes on a plain UDP socket from any
// source) refuses every complete frame that is not the size and pixel format its camera sends,
// as Foreign, with none of its pixels; without the guard the same flow is assembled as cam1's own.
TEST(StreamIsolation, AStreamRefusesAnotherCamerasFramesByTheirSizeAndFormat) {
  const std::vector<std::string> addresses{"127.0.0.2", "127.0.0.3"};
  if (!sim::addresses_present(addresses)) {
    ASSERT_TRUE(sim::enter_private_network(addresses).ok());
  }
  const fs::path work = pvcap::testing::work_dir("stream-foreign");
  std::ofstream(work / "rig.yaml") << pvcap::testing::sim_rig_yaml({{}, {}}, 320, 240, 60, 15);
  const RigConfig rig = load_rig_config(work / "rig.yaml");
  auto sim = sim::SimProcess::start(PVCAP_BIN, work / "rig.yaml", work / "truth", /*steerable=*/false);
  ASSERT_TRUE(sim) << sim.error().message;
  auto connect = [](const std::string& address) {
    arv::GPtr<ArvCamera> c;
    for (int t = 0; t < 50 && !c; ++t) {
      c.reset(arv_camera_new(address.c_str(), nullptr));
      if (!c) std::this_thread::sleep_for(100ms);
    }
    return c;
  };
  arv::GPtr<ArvCamera> sender = connect(rig.cameras[0].address), receiver = connect(rig.cameras[1].address);
  ASSERT_TRUE(sender && receiver);
  arv_camera_set_region(sender.get(), 0, 0, 320, 240, nullptr);    // cam0 sends 320 x 240
  arv_camera_set_region(receiver.get(), 0, 0, 160, 120, nullptr);  // cam1 would send 160 x 120
  arv_camera_set_pixel_format_from_string(receiver.get(), "BayerRG8", nullptr);
  ArvDevice* receiving = arv_camera_get_device(receiver.get());
  const auto payload = std::size_t(arv_camera_get_payload(sender.get(), nullptr));  // room for the foreign frame

  auto frames_through = [&](const ExpectedImage& expected, std::size_t& good, std::size_t& foreign) {
    BoundedQueue<FrameLoss> losses(1000);
    // On a UDP port of its own (the stream a reconnection makes): only what is sent there arrives, which
    // here is cam0's flow, sent there on purpose.
    auto stream = AravisStream::create(receiver.get(), 1, 0, payload, 8, false, 0, losses, expected, nullptr,
                                       StreamSocket::OwnPort);
    ASSERT_TRUE(stream) << stream.error().message;
    stream.value()->accept_from_now();
    // cam0 sends to where cam1's stream listens (the stream channel's bootstrap registers).
    constexpr guint64 kPort = 0x0D00, kAddress = 0x0D18;
    guint32 port = 0, address = 0;
    ASSERT_TRUE(arv_device_read_register(receiving, kAddress, &address, nullptr));
    ASSERT_TRUE(arv_device_read_register(receiving, kPort, &port, nullptr));
    ArvDevice* sending = arv_camera_get_device(sender.get());
    ASSERT_TRUE(arv_device_write_register(sending, kAddress, address, nullptr));
    ASSERT_TRUE(arv_device_write_register(sending, kPort, port, nullptr));
    arv_camera_start_acquisition(sender.get(), nullptr);
    for (auto until = std::chrono::steady_clock::now() + 700ms; std::chrono::steady_clock::now() < until;)
      while (auto f = stream.value()->take_frame(20ms)) {
        if (f->identity == FrameIdentity::Foreign) {
          ++foreign;
          EXPECT_NE(f->status, FrameStatus::Good);
          EXPECT_EQ(f->data, nullptr) << "a refused frame's pixels are never handed over";
        } else if (f->status == FrameStatus::Good) {
          ++good;
        }
      }
    arv_camera_stop_acquisition(sender.get(), nullptr);
    std::this_thread::sleep_for(100ms);
  };
  std::size_t good = 0, foreign = 0;
  frames_through({}, good, foreign);  // unguarded: the hazard is real
  std::printf("another camera's flow into a stream: unguarded %zu taken as its own;", good);
  EXPECT_GT(good, 5u) << "the foreign flow did not reach the stream: the test shows nothing";
  EXPECT_EQ(foreign, 0u);
  good = foreign = 0;
  frames_through({160, 120, pixel_format_code("BayerRG8")}, good, foreign);
  std::printf(" guarded %zu refused, %zu taken\n", foreign, good);
  EXPECT_GT(foreign, 5u);
  EXPECT_EQ(good, 0u) << "another camera's frame was taken as this camera's";
  sender.reset();
  receiver.reset();
  sim.value().reset();
}
