// The Sensel driver against the emulator: the whole open / configure / stream /
// close sequence, and the faults a lab sees. Built twice: over the tty transport
// (the emulator behind a pseudo-terminal) and, with PVCAP_SENSEL_OVER_USB, over
// the libusb transport (the emulator on umockdev's emulated USB bus; that binary
// runs under umockdev's preload library).
#include <gtest/gtest.h>

#include <algorithm>
#include <mutex>
#include <set>
#include <thread>

#include "capture/sensel_device.h"
#include "sim/sensel_emulator.h"
#ifdef PVCAP_SENSEL_OVER_USB
#include "sim/sensel_usb_device.h"
#define SenselDriver SenselDriverOverUsb
#else
#include "sim/sensel_pty.h"
#define SenselDriver SenselDriverOverTty
#endif

using namespace pvcap;
using namespace std::chrono_literals;

namespace {

struct Rig {
  // The device clock starts 0.7 s before its 32-bit wrap, counted from now.
  sim::SenselEmulator emu{sim::fingertip_scene(60.0, 60.0, 150.0, 0.5),
                          sim::SenselClock{host_now().ns, 4294967295.0 - 700'000.0, 50.0}};
#ifdef PVCAP_SENSEL_OVER_USB
  std::unique_ptr<sim::SenselUsbDevice> link;
#else
  std::unique_ptr<sim::SenselPty> link;
#endif
  std::unique_ptr<sensel::SenselDevice> device;
  std::mutex mu;
  std::vector<sensel::SenselEvent> events;

  void open() {
#ifdef PVCAP_SENSEL_OVER_USB
    auto l = sim::SenselUsbDevice::create(emu);
    ASSERT_TRUE(l) << l.error().message;
    link = std::move(l.value());
    const std::string serial = link->identity().serial;
    auto factory = [serial](const std::string&) { return sensel::open_usb(serial); };
#else
    auto l = sim::SenselPty::create(emu);
    ASSERT_TRUE(l) << l.error().message;
    link = std::move(l.value());
    auto factory = [path = link->slave_path()](const std::string&) { return sensel::open_tty(path); };
#endif
    auto d = sensel::SenselDevice::open(factory, [this](const sensel::SenselEvent& e) {
      std::lock_guard lock(mu);
      events.push_back(e);
    });
    ASSERT_TRUE(d) << d.error().message;
    device = std::move(d.value());
  }
  std::vector<sensel::PressureSample> drain() {
    std::vector<sensel::PressureSample> out;
    while (auto s = device->samples().pop_for(0ms)) out.push_back(std::move(*s));
    return out;
  }
  // Streams until n samples arrived (or 10 s passed), then stops. Rates are judged on the device's
  // clock: a loaded machine may deliver late, but must not lose or invent frames.
  std::vector<sensel::PressureSample> collect(std::size_t n) {
    std::vector<sensel::PressureSample> out;
    for (auto deadline = std::chrono::steady_clock::now() + 10s;
         out.size() < n && std::chrono::steady_clock::now() < deadline;) {
      std::this_thread::sleep_for(50ms);
      for (auto& s : drain()) out.push_back(std::move(s));
    }
    device->stop();
    for (auto& s : drain()) out.push_back(std::move(s));
    return out;
  }
  bool saw(sensel::SenselEvent::Kind kind) {
    std::lock_guard lock(mu);
    for (const auto& e : events)
      if (e.kind == kind) return true;
    return false;
  }
};

// Device-clock intervals between consecutive frames, sorted.
std::vector<double> intervals_ms(const std::vector<sensel::PressureSample>& s) {
  std::vector<double> out;
  for (std::size_t i = 1; i < s.size(); ++i) out.push_back(double(s[i].device_ts.ns - s[i - 1].device_ts.ns) / 1e6);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST(SenselDriver, OpensConfiguresAndStreams) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  EXPECT_EQ(rig.device->info().serial, "SM01164910368");
  EXPECT_EQ(rig.device->info().firmware, "0.16.78");
  ASSERT_TRUE(rig.device->configure({.scan_detail = 1}).ok());
  EXPECT_EQ(rig.emu.reg(0x57), 0) << "dynamic baselining must be switched off";
  EXPECT_EQ(rig.device->info().grid, sensel::kMediumDetail);
  ASSERT_TRUE(rig.device->start().ok());
  // Collect 1.5 s worth of frames at the device's rate; a loaded machine may take longer to deliver
  // them, so the rate is judged on the device's clock, not on how many arrived in a wall-clock window.
  const auto samples = rig.collect(188);
  ASSERT_GE(samples.size(), 188u);
  // A polled Morph scans when asked, no sooner than its scan period after the last scan: never
  // faster than 125 Hz, and at 125 Hz whenever the driver asks in time, which it must do for most
  // frames (a starved moment on a loaded machine stretches single intervals, not the median).
  const auto intervals = intervals_ms(samples);
  EXPECT_GE(intervals.front(), 7.99) << "faster than the device's scan period";
  EXPECT_NEAR(intervals[intervals.size() / 2], 8.0, 0.05) << "~125 Hz at medium detail (median interval)";
  EXPECT_EQ(rig.device->lost_frames(), 0u);
  bool pressed = false, wrapped = false;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    EXPECT_GT(samples[i].host_ts, samples[i - 1].host_ts);
    EXPECT_GT(samples[i].device_ts, samples[i - 1].device_ts) << "device time unwrapped past 2^32 us";
    EXPECT_EQ(samples[i].sequence, samples[i - 1].sequence + 1);
    wrapped |= samples[i].frame.timestamp_us < samples[i - 1].frame.timestamp_us;
    for (auto c : samples[i].frame.pressure->counts) pressed |= c > 0;
  }
  EXPECT_TRUE(wrapped) << "the emulated clock starts just before its 32-bit wrap";
  EXPECT_TRUE(pressed);
  EXPECT_LT(samples[5].host_wait_ns, 50'000'000) << "request-to-answer time bounds the stamp's error";
}

// A consumer that stops taking frames: the driver's queue (512) fills, further frames are dropped,
// and the next frame it hands over names exactly the sequences it dropped, so the store can
// record them as queue_overflow rather than as never received.
TEST(SenselDriver, FramesItsQueueHadNoRoomForAreNamedToTheNextFrame) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({.scan_detail = 1}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  // 512 frames fill the queue in ~4.1 s at 125 Hz; wait until some were dropped beyond it.
  for (auto deadline = std::chrono::steady_clock::now() + 20s;
       rig.device->queue_overflows() < 40 && std::chrono::steady_clock::now() < deadline;)
    std::this_thread::sleep_for(100ms);
  ASSERT_GE(rig.device->queue_overflows(), 40u);
  const auto samples = rig.collect(600);
  std::set<std::uint64_t> delivered, named;
  for (const auto& s : samples) {
    delivered.insert(s.sequence);
    for (auto q : s.dropped_before) {
      EXPECT_LT(q, s.sequence) << "a dropped frame is named by a later one";
      named.insert(q);
    }
  }
  EXPECT_EQ(named.size(), rig.device->queue_overflows()) << "every dropped frame is named once";
  for (auto q : named) EXPECT_EQ(delivered.count(q), 0u) << "sequence " << q << " both dropped and delivered";
  // Together, delivered and dropped frames leave no sequence unaccounted for (the emulator loses none).
  const std::uint64_t first = *delivered.begin(), last = *delivered.rbegin();
  EXPECT_EQ(delivered.size() + named.size(), last - first + 1);
  EXPECT_EQ(rig.device->lost_frames(), 0u);
}

TEST(SenselDriver, CorruptFrameIsRejectedAndCountedAndStreamingGoesOn) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  std::this_thread::sleep_for(300ms);
  rig.emu.corrupt_next_frame();
  std::this_thread::sleep_for(300ms);
  rig.emu.truncate_next_frame();  // half a frame, then nothing: a stall until the timeout
  std::this_thread::sleep_for(1000ms);
  const auto before = rig.device->frames();
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(rig.device->frames(), before) << "streaming stopped after the bad frames";
  rig.device->stop();
  const auto rejected = rig.device->rejected();
  EXPECT_EQ(rejected.count("checksum"), 1u);
  EXPECT_TRUE(rig.saw(sensel::SenselEvent::Kind::Garbage));
}

TEST(SenselDriver, StallIsReportedAndSurvived) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  std::this_thread::sleep_for(200ms);
  rig.link->stall_for(800);
  std::this_thread::sleep_for(1500ms);
  const auto before = rig.device->frames();
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(rig.device->frames(), before);
  rig.device->stop();
  EXPECT_TRUE(rig.saw(sensel::SenselEvent::Kind::Stall));
  EXPECT_GE(rig.device->rejected()["stall"], 1u);
}

TEST(SenselDriver, UnplugIsReportedAndNothingCapturedIsLost) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  std::this_thread::sleep_for(500ms);
  const auto t_unplug = host_now();
  rig.link->unplug();
  // Reported within a second: a read in flight gives up after the driver's timeout (0.5 s) at the
  // latest, and a loaded machine adds its scheduling (672 ms seen beside a CPU-heavy test).
  for (auto deadline = std::chrono::steady_clock::now() + 2s;
       !rig.saw(sensel::SenselEvent::Kind::Unplugged) && std::chrono::steady_clock::now() < deadline;)
    std::this_thread::sleep_for(20ms);
  EXPECT_TRUE(rig.saw(sensel::SenselEvent::Kind::Unplugged));
  {
    std::lock_guard lock(rig.mu);
    for (const auto& e : rig.events)
      if (e.kind == sensel::SenselEvent::Kind::Unplugged) {
        EXPECT_LT(e.at.ns - t_unplug.ns, 1'000'000'000);
      }
  }
  const auto frames = rig.device->frames();
  const auto start = std::chrono::steady_clock::now();
  rig.device->stop();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2500ms) << "stop must not hang on a vanished device";
  EXPECT_EQ(rig.drain().size(), frames) << "every frame captured before the unplug is still delivered";
}

TEST(SenselDriver, VariableSizeRegisterIsWrittenInAcknowledgedChunks) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  std::vector<std::uint8_t> brightness(1100);  // three chunks: 512 + 512 + 76
  for (std::size_t i = 0; i < brightness.size(); ++i) brightness[i] = std::uint8_t(i % 251);
  ASSERT_TRUE(rig.device->write_variable(0x80, brightness).ok());
  EXPECT_EQ(rig.emu.variable_reg(0x80), brightness);
  ASSERT_TRUE(rig.device->configure({}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  const auto refused = rig.device->write_variable(0x80, brightness);
  EXPECT_FALSE(refused.ok()) << "the channel belongs to the stream while it runs";
  rig.device->stop();
}

TEST(SenselDriver, HighDetailRunsAtTheDevicesSlowerRate) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({.scan_detail = 0}).ok());
  EXPECT_EQ(rig.device->info().grid, sensel::kHighDetail);
  ASSERT_TRUE(rig.device->start().ok());
  const auto samples = rig.collect(100);
  ASSERT_GE(samples.size(), 100u);
  // At most ~51 Hz (19.6 ms per scan), slower while the fingertip makes frames bigger.
  const auto intervals = intervals_ms(samples);
  EXPECT_GE(intervals.front(), 19.59);
  EXPECT_LT(intervals[intervals.size() / 2], 33.0) << "median interval";
  EXPECT_EQ(samples.back().frame.pressure->counts.size(), std::size_t(93 * 53));
}

// A Morph that falls back to medium detail when its scan starts (after a stop or a reset) is set
// again once it scans, and read back: the session gets the high detail the rig file asks for.
TEST(SenselDriver, SettingsAreSetAgainOnceTheScanStartsAndReadBack) {
  Rig rig;
  rig.emu.revert_detail_on_scan_start();
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({.scan_detail = 0}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  EXPECT_EQ(rig.emu.reg(0x23), 0) << "high detail, set again after the scan started";
  EXPECT_EQ(rig.device->info().grid, sensel::kHighDetail);
  const auto samples = rig.collect(20);
  ASSERT_GE(samples.size(), 20u);
  EXPECT_EQ(samples.back().frame.pressure->counts.size(), std::size_t(93 * 53));
}

// A setting that does not take is an error naming it, before a frame is recorded.
TEST(SenselDriver, ASettingThatDoesNotTakeIsNamed) {
  Rig rig;
  rig.emu.ignore_writes_to(0x57);  // dynamic baseline stays on, as the device's default
  ASSERT_NO_FATAL_FAILURE(rig.open());
  const Status s = rig.device->configure({.scan_detail = 1});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("the Morph's dynamic baseline reads back 1, not the 0 set (register 0x57)"),
            std::string::npos)
      << s.error().message;
}

#ifdef PVCAP_SENSEL_OVER_USB
// What only the USB transport does: find the Morph by its USB serial, take the CDC data
// interface from the kernel's cdc_acm (and give it back), refuse a second program, and
// follow the device through a replug to its new bus address.

TEST(SenselDriverOverUsb, TakesTheInterfaceFromCdcAcmAndGivesItBack) {
  Rig rig;
  auto l = sim::SenselUsbDevice::create(rig.emu);
  ASSERT_TRUE(l) << l.error().message;
  auto& usb = *l.value();
  EXPECT_TRUE(usb.cdc_acm_bound(0) && usb.cdc_acm_bound(1));
  {
    auto t = sensel::open_usb(usb.identity().serial);
    ASSERT_TRUE(t) << t.error().message;
    EXPECT_FALSE(usb.cdc_acm_bound(0));
    EXPECT_FALSE(usb.cdc_acm_bound(1));
    EXPECT_NE(t.value()->describe().find("2044B8374E33"), std::string::npos) << t.value()->describe();

    // A second program (another pvcap, the Sensel app) cannot take the Morph away.
    auto second = sensel::open_usb("");
    ASSERT_FALSE(second);
    EXPECT_NE(second.error().message.find("another program"), std::string::npos) << second.error().message;
  }
  EXPECT_TRUE(usb.cdc_acm_bound(0) && usb.cdc_acm_bound(1)) << "closing gives /dev/ttyACM back to the kernel";
}

TEST(SenselDriverOverUsb, NamesWhatItFoundWhenTheSerialIsWrongOrTheMorphIsMissing) {
  Rig rig;
  auto l = sim::SenselUsbDevice::create(rig.emu);
  ASSERT_TRUE(l) << l.error().message;
  auto listed = sensel::list_usb_sensels();
  ASSERT_TRUE(listed) << listed.error().message;
  EXPECT_EQ(listed.value(), std::vector<std::string>{"2044B8374E33"});

  auto wrong = sensel::open_usb("SM01164910368");  // register 0x0F's serial, not the USB one
  ASSERT_FALSE(wrong);
  EXPECT_NE(wrong.error().message.find("'SM01164910368'"), std::string::npos) << wrong.error().message;
  EXPECT_NE(wrong.error().message.find("found: 2044B8374E33"), std::string::npos) << wrong.error().message;

  l.value()->unplug();
  auto none = sensel::open_usb("");
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().message.find("no Sensel Morph"), std::string::npos) << none.error().message;
}

TEST(SenselDriverOverUsb, ReplugIsFollowedToTheNewAddressAndStreamingResumes) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  std::this_thread::sleep_for(400ms);
  const std::string first_node = rig.link->devnode();
  rig.link->unplug();
  std::this_thread::sleep_for(700ms);
  EXPECT_TRUE(rig.saw(sensel::SenselEvent::Kind::Unplugged));
  const auto frames_while_gone = rig.device->frames();
  rig.link->plug_in();
  EXPECT_NE(rig.link->devnode(), first_node);
  std::this_thread::sleep_for(2500ms);  // the driver retries every second
  EXPECT_TRUE(rig.saw(sensel::SenselEvent::Kind::Reconnected));
  EXPECT_GT(rig.device->frames(), frames_while_gone + 50) << "streaming did not resume after the replug";
  rig.device->stop();
  EXPECT_EQ(rig.drain().size(), rig.device->frames());
}
#endif

#ifndef PVCAP_SENSEL_OVER_USB
// One reader per Morph: while a session streams from a tty, a second open (another recorder,
// `pvcap devices`) is refused before it writes a byte, and the stream goes on untouched.
TEST(SenselDriver, ASecondOpenOfAStreamingTtyIsRefusedAndTheStreamGoesOn) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.open());
  ASSERT_TRUE(rig.device->configure({.scan_detail = 1}).ok());
  ASSERT_TRUE(rig.device->start().ok());
  std::this_thread::sleep_for(300ms);
  const auto before = rig.drain().size();
  auto second = sensel::open_tty(rig.link->slave_path());
  ASSERT_FALSE(second);
  EXPECT_NE(second.error().message.find("in use by another pvcap"), std::string::npos) << second.error().message;
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(before, 10u);
  EXPECT_GT(rig.drain().size(), 10u) << "the first reader still streams";
  EXPECT_FALSE(rig.saw(sensel::SenselEvent::Kind::Unplugged));
}
#endif
