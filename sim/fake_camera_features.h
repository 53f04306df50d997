#pragma once
// What real GigE cameras offer and Aravis' fake camera lacks, for every simulated camera
// (sim_camera.h, replay_camera.h):
// - the timestamp latch (SFNC `TimestampControlLatch` + `TimestampLatchValue`): the device clock
//   is latched within 0.2 ms of its command register being set (the host polls the value);
// - a trigger line: the fake engine fills a frame only free-running or on a software trigger, so
//   `TriggerSource` is moved to a register of ours, the engine is left in software-trigger mode,
//   and a camera set to a line (`Line0`) is triggered at the line's pulses, which fall at whole
//   periods of CLOCK_MONOTONIC: every camera on a line of one rate is triggered together, as by
//   one wire. `Software` still triggers on the host's `TriggerSoftware` alone.
// The fake cameras serve their GenICam XML with these features; one thread serves them all.
// A simulated camera's node map names its features as Aravis' fake camera does (ExposureTimeAbs,
// GainRaw, TimestampControlLatch), or as SFNC 2 cameras do (ExposureTime, Gain, TimestampLatch, a
// rate that takes only with AcquisitionFrameRateEnable, and chunk data: each frame's FrameID,
// Timestamp, ExposureTime and Gain), on the same registers: the live camera code is exercised
// through real GVCP against two naming families.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "capture/aravis_handles.h"
#include "sim/sim_config.h"

namespace pvcap::sim {

inline constexpr std::uint32_t kLatchCommandRegister = 0xF000;
inline constexpr std::uint32_t kLatchValueRegister = 0xF008;        // 64 bits: high word, then low
inline constexpr std::uint32_t kTriggerSourceRegister = 0xF010;     // 0 = Line0, 1 = Software (the XML's values)
inline constexpr std::uint32_t kFrameRateEnableRegister = 0xF014;   // SFNC 2 map: AcquisitionFrameRateEnable
inline constexpr std::uint32_t kFramePeriodRegister = 0xF018;       // SFNC 2 map: the rate asked, as a period (us)
inline constexpr std::uint32_t kBalanceWhiteAutoRegister = 0xF01C;  // SFNC 2 map: 0 Off, 2 Continuous
// SFNC 2 map: ChunkModeActive, ChunkSelector (0 FrameID, 1 Timestamp, 2 ExposureTime, 3 Gain,
// 4 LineStatusAll) and ChunkEnable (one for all: the camera sends its five chunks together,
// sim/gvsp_sender.h).
inline constexpr std::uint32_t kChunkModeRegister = 0xF020;
inline constexpr std::uint32_t kChunkSelectorRegister = 0xF024;
inline constexpr std::uint32_t kChunkEnableRegister = 0xF028;
// SFNC 2 map: DeviceTemperature, in tenths of a degree: 40 C when served, rising 0.5 C a second.
inline constexpr std::uint32_t kDeviceTemperatureRegister = 0xF030;
// SFNC 2 map: its lines' levels as served (bit N: LineN high), which each frame's ChunkLineStatusAll carries.
inline constexpr std::uint32_t kLineStatusRegister = 0xF034;
// Every map: output lines as SFNC names them (LineSelector Line0-Line3, LineSource Off,
// ExposureActive, UserOutput1-3; UserOutputSelector, UserOutputValue), a register per line and per
// user output (selected by GenICam's pIndex), which drive the simulated rig's lamps (sim/lights.h).
inline constexpr std::uint32_t kLineSelectorRegister = 0xF040;
inline constexpr std::uint32_t kLineSourceRegister = 0xF044;  // + 4 x line
inline constexpr std::uint32_t kUserOutputSelectorRegister = 0xF054;
inline constexpr std::uint32_t kUserOutputValueRegister = 0xF058;  // + 4 x output
inline constexpr int kOutputLines = 4, kUserOutputs = 3;
// SFNC 2 map: PTP as a Basler ace 2 names it. PtpEnable; PtpStatus (0 Disabled, 2 Listening,
// 3 Uncalibrated, 4 Slave) and PtpServoStatus (0 Unknown, 1 Locked) as they are now;
// PtpDataSetLatch, which latches PtpOffsetFromMaster (ns, signed).
inline constexpr std::uint32_t kPtpEnableRegister = 0xF070;
inline constexpr std::uint32_t kPtpLatchRegister = 0xF074;
inline constexpr std::uint32_t kPtpStatusRegister = 0xF078;
inline constexpr std::uint32_t kPtpServoRegister = 0xF07C;
inline constexpr std::uint32_t kPtpOffsetRegister = 0xF080;

// How a simulated camera's PTP behaves once enabled (sim_config.h: ptp_lock_after_s, ...).
struct PtpBehaviour {
  double lock_after_s = 1.0;
  double servo_error_ns = 50.0;
  std::optional<double> unlock_at_s;
  double unlock_for_s = 5.0;
};

// The raw map's ExposureTimeBaseAbs: one step of its ExposureTimeRaw (Basler's ace classic default).
inline constexpr double kRawExposureStepUs = 20.0;

// The GenICam file a fake camera of this naming serves (arv_gv_fake_camera_new_full); written once
// per process, named by its content.
std::string fake_camera_genicam(NodeMapNaming naming);

// The device clock of a simulated camera: its time at a host instant (CLOCK_MONOTONIC ns).
using DeviceClock = std::function<std::int64_t(std::int64_t host_ns)>;

// A trigger line: the index of its latest pulse at a host instant (non-decreasing; each increase
// is one pulse). Null: the camera is on no line.
using TriggerLine = std::function<std::int64_t(std::int64_t host_ns)>;
// A line pulsing at `hz` at whole periods of CLOCK_MONOTONIC (every camera on it together).
TriggerLine periodic_line(double hz);

// A camera's output lines as the host has set them (bit N: LineN is driven high), at each change.
using OutputLines = std::function<void(std::uint32_t line_mask, std::int64_t host_ns)>;

// Serves `fake`'s latch with `clock`, its trigger line, and its output lines to `outputs` (when
// given), until stop_serving(owner); after stop_serving returns, neither `fake` nor `clock` nor
// `line` nor `outputs` is touched again. A pulse reaches the
// camera only while it is set to be triggered by its line (TriggerMode On, TriggerSource Line0);
// until then the line waits for it.
// With the SFNC 2 naming, its rate is served too (the engine takes the rate asked only while the
// enable is on).
void serve_features(const void* owner, ArvFakeCamera* fake, DeviceClock clock, TriggerLine line,
                    NodeMapNaming naming = NodeMapNaming::Aravis, OutputLines outputs = {}, PtpBehaviour ptp = {});
void stop_serving(const void* owner);

}  // namespace pvcap::sim
