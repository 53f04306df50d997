#include <gtest/gtest.h>

#include "codec/sensel_frame.h"
#include "codec/sensel_protocol.h"
#include "codec/sensel_units.h"
#include "sim/sensel_emulator.h"

using namespace pvcap::sensel;
using pvcap::sim::SenselEmulator;

namespace {
// Sends one command and parses the single answer the way the driver does.
Response ask(SenselEmulator& emu, const std::vector<std::uint8_t>& cmd, Expect expect, std::uint8_t reg,
             std::uint8_t size = 0, std::int64_t now_ns = 0) {
  const auto answer = emu.on_host_bytes(cmd, now_ns);
  Response r = parse_response(answer, expect, reg, size);
  EXPECT_EQ(r.consumed, answer.size());
  return r;
}
}  // namespace

TEST(SenselEmulator, AnswersTheOpenSequenceLikeTheDevice) {
  SenselEmulator emu({}, {});
  auto magic = ask(emu, command_read(reg::kMagic, 6), Expect::Read, reg::kMagic, 6);
  ASSERT_EQ(magic.state, Response::State::Ok) << magic.error;
  EXPECT_EQ(std::string(magic.data.begin(), magic.data.end()), "S3NS31");
  const std::uint8_t one[] = {1};
  EXPECT_EQ(ask(emu, command_write(reg::kSoftReset, one), Expect::Write, reg::kSoftReset).state, Response::State::Ok);
  auto cols = ask(emu, command_read(reg::kSensorCols, 2), Expect::Read, reg::kSensorCols, 2);
  EXPECT_EQ(cols.data, (std::vector<std::uint8_t>{185, 0}));
  auto serial = ask(emu, command_read_variable(reg::kSerialNumber), Expect::ReadVariable, reg::kSerialNumber);
  ASSERT_EQ(serial.data.size(), 16u);
  EXPECT_EQ(serial.data[15], 0xFF);  // 13 characters and 0xFF padding
  auto meta =
      ask(emu, command_read_variable(reg::kCompressionMetadata), Expect::ReadVariable, reg::kCompressionMetadata);
  EXPECT_EQ(grid_from_metadata(meta.data).value(), kMediumDetail);  // medium after reset
  const std::uint8_t high[] = {0};
  ask(emu, command_write(reg::kScanDetail, high), Expect::Write, reg::kScanDetail);
  meta = ask(emu, command_read_variable(reg::kCompressionMetadata), Expect::ReadVariable, reg::kCompressionMetadata);
  EXPECT_EQ(grid_from_metadata(meta.data).value(), kHighDetail);
  EXPECT_EQ(emu.reg(reg::kDynamicBaseline), 1) << "dynamic baselining is on by default, as on the device";
}

TEST(SenselEmulator, WriteWithABadChecksumIsRefused) {
  SenselEmulator emu({}, {});
  std::vector<std::uint8_t> cmd = {0x01, reg::kScanDetail, 0x01, 0x00, 0x07};  // checksum should be 0
  const auto answer = emu.on_host_bytes(cmd, 0);
  EXPECT_EQ(answer, (std::vector<std::uint8_t>{kWriteNack, reg::kScanDetail}));
  EXPECT_EQ(emu.reg(reg::kScanDetail), 1);
}

TEST(SenselEmulator, KnownPressDecodesToTheDocumentedPressure) {
  // 200 g peak on the centre cell at the top of the press (a quarter of the 2 s period).
  pvcap::sim::SenselEmulator emu(pvcap::sim::fingertip_scene(100.0, 50.0, 200.0, 2.0), {});
  const std::uint8_t high[] = {0};
  ask(emu, command_write(reg::kScanDetail, high), Expect::Write, reg::kScanDetail);
  const std::uint8_t content[] = {kPressure | kLabels | kContacts | kAccel};
  ask(emu, command_write(reg::kFrameContent, content), Expect::Write, reg::kFrameContent);
  const auto r =
      ask(emu, command_read_variable(reg::kReadFrame), Expect::ReadVariable, reg::kReadFrame, 0, 500'000'000);
  ASSERT_EQ(r.state, Response::State::Ok) << r.error;
  auto f = parse_frame(r.data, kHighDetail);
  ASSERT_TRUE(f) << f.error().message;
  ASSERT_TRUE(f.value().pressure && f.value().accel);
  EXPECT_EQ(f.value().contacts.size(), 1u);
  // The centre cell (100 mm / 2.5 = column 40, 50 mm / 2.5 = row 20).
  const std::uint16_t centre = f.value().pressure->counts[20 * 93 + 40];
  EXPECT_NEAR(counts_to_grams(centre), 200.0, 0.2);
  // 200 g on 2.5 x 2.5 mm: 1.96133 N / 6.25e-6 m^2 = 313.8 kPa.
  EXPECT_NEAR(native_cell_kpa(centre, kHighDetail), 313.81, 0.5);
  // Labels mark the pressed cells with the contact's id.
  EXPECT_EQ((*f.value().labels)[20 * 93 + 40], 0);
  EXPECT_EQ((*f.value().labels)[0], kNoLabel);
}

TEST(SenselEmulator, FaultInjectionBreaksExactlyOneFrame) {
  SenselEmulator emu(pvcap::sim::fingertip_scene(100, 50, 100, 2.0), {});
  emu.corrupt_next_frame();
  auto bad = ask(emu, command_read_variable(reg::kReadFrame), Expect::ReadVariable, reg::kReadFrame);
  EXPECT_EQ(bad.state, Response::State::Bad);
  EXPECT_NE(bad.error.find("checksum"), std::string::npos);
  auto good = ask(emu, command_read_variable(reg::kReadFrame), Expect::ReadVariable, reg::kReadFrame);
  EXPECT_EQ(good.state, Response::State::Ok);
  emu.truncate_next_frame();
  const auto cut = emu.on_host_bytes(command_read_variable(reg::kReadFrame), 0);
  EXPECT_EQ(parse_response(cut, Expect::ReadVariable, reg::kReadFrame).state, Response::State::NeedMore);
}

TEST(SenselEmulator, TimestampsFollowItsOwnClockAndWrap) {
  pvcap::sim::SenselClock clock{0, 4294967295.0 - 500'000.0, 100.0};  // 0.5 s before the 32-bit wrap
  SenselEmulator emu({}, clock);
  std::vector<std::uint32_t> ts;
  for (std::int64_t t : {0LL, 400'000'000LL, 800'000'000LL}) {
    auto r = ask(emu, command_read_variable(reg::kReadFrame), Expect::ReadVariable, reg::kReadFrame, 0, t);
    ts.push_back(parse_frame(r.data, kMediumDetail).value().timestamp_us);
  }
  EXPECT_LT(ts[2], ts[1]) << "the device clock wraps past 2^32 us";
  EXPECT_NEAR(double(ts[1] - ts[0]), 400'000.0 * 1.0001, 2.0);  // 100 ppm fast
}

TEST(SenselEmulator, BufferedScanningReturnsEveryScanSinceTheLastReadThenATerminator) {
  SenselEmulator emu({}, {});
  const std::uint8_t five[] = {5};
  ask(emu, command_write(reg::kScanBufferControl, five), Expect::Write, reg::kScanBufferControl);
  const std::uint8_t sync[] = {1};
  ask(emu, command_write(reg::kScanEnabled, sync), Expect::Write, reg::kScanEnabled, 0, 1'000'000'000);
  (void)emu.on_host_bytes(command_read_variable(reg::kReadFrame), 1'000'000'000);  // drains the first scan
  // 30 ms later at medium detail (8 ms per scan): the scans of +8, +16 and +24 ms are due.
  auto wire = emu.on_host_bytes(command_read_variable(reg::kReadFrame), 1'030'000'000);
  std::vector<std::uint32_t> stamps;
  std::span<const std::uint8_t> rest(wire);
  for (;;) {
    const Response r = parse_response(rest, Expect::ReadVariable, reg::kReadFrame);
    ASSERT_EQ(r.state, Response::State::Ok) << r.error;
    rest = rest.subspan(r.consumed);
    if (r.ack == kBufferedEnd) break;
    stamps.push_back(parse_frame(r.data, kMediumDetail).value().timestamp_us);
  }
  EXPECT_TRUE(rest.empty());
  ASSERT_EQ(stamps.size(), 3u);
  for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_EQ(stamps[i] - stamps[i - 1], 8000u);
  // 100 ms later: 13 scans are due, the 5-frame buffer keeps the newest 5.
  wire = emu.on_host_bytes(command_read_variable(reg::kReadFrame), 1'130'000'000);
  std::size_t frames = 0;
  rest = wire;
  while (true) {
    const Response r = parse_response(rest, Expect::ReadVariable, reg::kReadFrame);
    ASSERT_EQ(r.state, Response::State::Ok);
    rest = rest.subspan(r.consumed);
    if (r.ack == kBufferedEnd) break;
    ++frames;
  }
  EXPECT_EQ(frames, 5u);
}

TEST(SenselEmulator, AsyncScanningPushesFramesUnasked) {
  SenselEmulator emu({}, {});
  EXPECT_TRUE(emu.async_frames_due(0).empty()) << "nothing is pushed unless async scanning is on";
  const std::uint8_t async[] = {2};
  ask(emu, command_write(reg::kScanEnabled, async), Expect::Write, reg::kScanEnabled);
  (void)emu.async_frames_due(2'000'000'000);
  const auto wire = emu.async_frames_due(2'040'000'000);  // 40 ms at 8 ms per scan
  std::span<const std::uint8_t> rest(wire);
  int frames = 0;
  while (!rest.empty()) {
    // A driver waiting for a write ack must see these as async frames first.
    const Response r = parse_response(rest, Expect::Write, reg::kScanEnabled);
    ASSERT_EQ(r.state, Response::State::Ok) << r.error;
    EXPECT_EQ(r.ack, kAsyncData);
    EXPECT_TRUE(parse_frame(r.data, kMediumDetail));
    rest = rest.subspan(r.consumed);
    ++frames;
  }
  EXPECT_EQ(frames, 5);
}

TEST(SenselEmulator, VariableWriteArrivesInChunksAndABadChunkIsRefused) {
  SenselEmulator emu({}, {});
  std::vector<std::uint8_t> leds(700);
  for (std::size_t i = 0; i < leds.size(); ++i) leds[i] = std::uint8_t(i * 7);
  EXPECT_EQ(ask(emu, command_write_variable_header(0x80, 700), Expect::WriteVariableHeader, 0x80).state,
            Response::State::Ok);
  const std::span<const std::uint8_t> all(leds);
  EXPECT_EQ(ask(emu, command_write_variable_chunk(all.subspan(0, 512)), Expect::WriteVariableChunk, 0x80).state,
            Response::State::Ok);
  EXPECT_TRUE(emu.variable_reg(0x80).empty()) << "stored only when complete";
  // The last chunk arrives cut in two pieces, as USB packets may.
  const auto last = command_write_variable_chunk(all.subspan(512));
  EXPECT_TRUE(emu.on_host_bytes(std::span(last).subspan(0, 50), 0).empty());
  const auto ack = emu.on_host_bytes(std::span(last).subspan(50), 0);
  EXPECT_EQ(parse_response(ack, Expect::WriteVariableChunk, 0x80).state, Response::State::Ok);
  EXPECT_EQ(emu.variable_reg(0x80), leds);

  EXPECT_EQ(ask(emu, command_write_variable_header(0x80, 4), Expect::WriteVariableHeader, 0x80).state,
            Response::State::Ok);
  auto bad = command_write_variable_chunk(std::vector<std::uint8_t>{1, 2, 3, 4});
  bad.back() ^= 0xFF;
  EXPECT_EQ(ask(emu, bad, Expect::WriteVariableChunk, 0x80).state, Response::State::Bad);
  EXPECT_EQ(emu.variable_reg(0x80), leds) << "a refused write changes nothing";
  // The channel is back to commands afterwards.
  EXPECT_EQ(ask(emu, command_read(reg::kSensorCols, 2), Expect::Read, reg::kSensorCols, 2).state, Response::State::Ok);
}
