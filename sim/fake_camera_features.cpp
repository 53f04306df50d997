#include "sim/fake_camera_features.h"

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "core/time.h"
#include "sim/gvsp_sender.h"

namespace pvcap::sim {

namespace {
// Writes `text` to a file named by its content (every simulator process shares one file instead of
// leaving one each), aside and renamed into place so a concurrent reader never sees half of it.
std::string write_by_content(const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path();
  const auto path = dir / fmt::format("pvcap-fake-camera-{:016x}.xml", std::hash<std::string>{}(text));
  if (!std::filesystem::exists(path)) {
    const auto aside = dir / fmt::format("pvcap-fake-camera-{}.xml.tmp", getpid());
    std::ofstream(aside) << text;
    std::error_code ec;
    std::filesystem::rename(aside, path, ec);
    if (ec) std::filesystem::remove(aside, ec);
  }
  return path.string();
}

void replace_all(std::string& text, const std::string& from, const std::string& to) {
  for (auto at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
}

// Output lines, as SFNC names them: the selected line's source and the selected user output's value
// each in a register of their own (GenICam's pIndex: the selector's value x 4 past the first).
std::string output_line_features() {
  const auto entries = [](const char* stem, int first, int count, int value0) {
    std::string e;
    for (int i = 0; i < count; ++i)
      e += fmt::format("<EnumEntry Name=\"{}{}\"><Value>{}</Value></EnumEntry>", stem, first + i, value0 + i);
    return e;
  };
  const auto reg = [](const char* name, std::uint32_t address, const char* index) {
    return fmt::format(
        R"(<IntReg Name="{}" NameSpace="Custom"><Address>{:#x}</Address>{}<Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
)",
        name, address, index ? fmt::format("<pIndex Offset=\"4\">{}</pIndex>", index) : std::string());
  };
  std::string x = fmt::format(
      R"(<Enumeration Name="LineSelector" NameSpace="Standard"><pSelected>LineSource</pSelected>{}
<pValue>PvcapLineSelectorRegister</pValue></Enumeration>
<Enumeration Name="LineSource" NameSpace="Standard"><EnumEntry Name="Off"><Value>0</Value></EnumEntry>
<EnumEntry Name="ExposureActive"><Value>1</Value></EnumEntry>{}<pValue>PvcapLineSourceRegister</pValue></Enumeration>
<Enumeration Name="UserOutputSelector" NameSpace="Standard"><pSelected>UserOutputValue</pSelected>{}
<pValue>PvcapUserOutputSelectorRegister</pValue></Enumeration>
<Boolean Name="UserOutputValue" NameSpace="Standard"><pValue>PvcapUserOutputValueRegister</pValue></Boolean>
)",
      entries("Line", 0, kOutputLines, 0), entries("UserOutput", 1, kUserOutputs, 2),
      entries("UserOutput", 1, kUserOutputs, 0));
  x += reg("PvcapLineSelectorRegister", kLineSelectorRegister, nullptr);
  x += reg("PvcapLineSourceRegister", kLineSourceRegister, "PvcapLineSelectorRegister");
  x += reg("PvcapUserOutputSelectorRegister", kUserOutputSelectorRegister, nullptr);
  x += reg("PvcapUserOutputValueRegister", kUserOutputValueRegister, "PvcapUserOutputSelectorRegister");
  return x;
}

// Aravis' own map with the features above; `latch` names the latch command.
std::string aravis_map_with_features(const char* latch) {
  arv::GPtr<ArvFakeCamera> probe(arv_fake_camera_new("PVSIM-XML"));
  size_t size = 0;
  const char* xml = probe ? arv_fake_camera_get_genicam_xml(probe.get(), &size) : nullptr;
  if (!xml) return "";
  std::string text(xml, size);
  while (!text.empty() && text.back() == '\0') text.pop_back();
  const std::string features = fmt::format(
      R"(<Command Name="{}" NameSpace="Standard">
<ToolTip>Latches the device clock into TimestampLatchValue</ToolTip>
<pValue>PvcapTimestampLatchCommand</pValue><CommandValue>1</CommandValue></Command>
<IntReg Name="PvcapTimestampLatchCommand" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<IntReg Name="TimestampLatchValue" NameSpace="Standard"><Address>{:#x}</Address><Length>8</Length>
<AccessMode>RO</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<IntReg Name="PvcapTriggerSourceRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
)",
      latch, kLatchCommandRegister, kLatchValueRegister, kTriggerSourceRegister);
  const auto end = text.rfind("</RegisterDescription>");
  if (end == std::string::npos) return "";
  text.insert(end, features + output_line_features());
  // TriggerSource reads and writes our register; the engine's own stays at Software (set per camera).
  const auto source = text.find("<Enumeration Name=\"TriggerSource\"");
  const std::string engine_register = "<pValue>TriggerSourceRegister</pValue>";
  const auto value = source == std::string::npos ? std::string::npos : text.find(engine_register, source);
  if (value != std::string::npos)
    text.replace(value, engine_register.size(), "<pValue>PvcapTriggerSourceRegister</pValue>");
  return text;
}

// The same registers under SFNC 2's names, as a FLIR Blackfly S or a Basler ace 2 declares them:
// TimestampLatch, ExposureTime, Gain as a Float, BalanceWhiteAuto (which pvcap leaves as it finds
// it: the report warns when it is on), and a rate that takes only with AcquisitionFrameRateEnable on (the rate the host
// writes goes to a register of ours, copied to the engine's while the enable is on; the engine otherwise keeps its own
// rate, which then reads back).
std::string sfnc2_map() {
  std::string text = aravis_map_with_features("TimestampLatch");
  if (text.empty()) return text;
  replace_all(text, "ExposureTimeAbs", "ExposureTime");
  replace_all(text, "GainRaw", "PvcapGainRaw");
  replace_all(text, "<pValue>AcquisitionFramePeriodRegister</pValue>", "<pValue>PvcapFramePeriodRegister</pValue>");
  replace_all(text, "ModelName=\"Fake\"", "ModelName=\"Fake SFNC 2\"");
  const std::string features = fmt::format(
      R"(<Float Name="Gain" NameSpace="Standard"><ToolTip>Gain, in dB</ToolTip>
<pValue>PvcapGainConverter</pValue><Min>0</Min><Max>10</Max></Float>
<Converter Name="PvcapGainConverter" NameSpace="Custom"><FormulaTo>FROM</FormulaTo><FormulaFrom>TO</FormulaFrom>
<pValue>PvcapGainRaw</pValue></Converter>
<Boolean Name="AcquisitionFrameRateEnable" NameSpace="Standard"><pValue>PvcapFrameRateEnableRegister</pValue></Boolean>
<IntReg Name="PvcapFrameRateEnableRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<IntReg Name="PvcapFramePeriodRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Enumeration Name="BalanceWhiteAuto" NameSpace="Standard"><ToolTip>Automatic white balance</ToolTip>
<EnumEntry Name="Off"><Value>0</Value></EnumEntry><EnumEntry Name="Continuous"><Value>2</Value></EnumEntry>
<pValue>PvcapBalanceWhiteAutoRegister</pValue></Enumeration>
<IntReg Name="PvcapBalanceWhiteAutoRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Float Name="AcquisitionResultingFrameRate" NameSpace="Standard"><ToolTip>The rate it reaches at its region: its sensor reads 200 Mpixel/s</ToolTip>
<pValue>PvcapResultingFrameRate</pValue></Float>
<SwissKnife Name="PvcapResultingFrameRate" NameSpace="Custom"><pVariable Name="W">Width</pVariable><pVariable Name="H">Height</pVariable>
<Formula>200000000 / (W * H)</Formula></SwissKnife>
<Float Name="DeviceTemperature" NameSpace="Standard"><ToolTip>Device temperature, in degrees Celsius</ToolTip>
<pValue>PvcapTemperatureConverter</pValue><Unit>C</Unit></Float>
<Converter Name="PvcapTemperatureConverter" NameSpace="Custom"><FormulaTo>FROM * 10</FormulaTo><FormulaFrom>TO / 10</FormulaFrom>
<pValue>PvcapTemperatureRegister</pValue></Converter>
<IntReg Name="PvcapTemperatureRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RO</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Boolean Name="PtpEnable" NameSpace="Standard"><ToolTip>PTP on</ToolTip><pValue>PvcapPtpEnableRegister</pValue></Boolean>
<IntReg Name="PvcapPtpEnableRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Command Name="PtpDataSetLatch" NameSpace="Standard"><ToolTip>Latches the PTP data set (PtpOffsetFromMaster)</ToolTip>
<pValue>PvcapPtpLatchRegister</pValue><CommandValue>1</CommandValue></Command>
<IntReg Name="PvcapPtpLatchRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Enumeration Name="PtpStatus" NameSpace="Standard"><ToolTip>The PTP port's state</ToolTip>
<EnumEntry Name="Disabled"><Value>0</Value></EnumEntry><EnumEntry Name="Listening"><Value>2</Value></EnumEntry>
<EnumEntry Name="Uncalibrated"><Value>3</Value></EnumEntry><EnumEntry Name="Slave"><Value>4</Value></EnumEntry>
<pValue>PvcapPtpStatusRegister</pValue></Enumeration>
<IntReg Name="PvcapPtpStatusRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RO</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Enumeration Name="PtpServoStatus" NameSpace="Standard"><ToolTip>The PTP clock servo's state</ToolTip>
<EnumEntry Name="Unknown"><Value>0</Value></EnumEntry><EnumEntry Name="Locked"><Value>1</Value></EnumEntry>
<pValue>PvcapPtpServoRegister</pValue></Enumeration>
<IntReg Name="PvcapPtpServoRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RO</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
<Integer Name="PtpOffsetFromMaster" NameSpace="Standard"><ToolTip>Offset from the PTP master at the last PtpDataSetLatch, ns</ToolTip>
<pValue>PvcapPtpOffsetRegister</pValue><Unit>ns</Unit></Integer>
<IntReg Name="PvcapPtpOffsetRegister" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RO</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Signed</Sign><Endianess>BigEndian</Endianess></IntReg>
)",
      kFrameRateEnableRegister, kFramePeriodRegister, kBalanceWhiteAutoRegister, kDeviceTemperatureRegister,
      kPtpEnableRegister, kPtpLatchRegister, kPtpStatusRegister, kPtpServoRegister, kPtpOffsetRegister);
  text.insert(text.rfind("</RegisterDescription>"), features);
  // Chunk data: the five values each frame carries (sim/gvsp_sender.h sends them), and a payload that
  // grows by them while chunk mode is on.
  const auto int_register = [](const char* name, std::uint32_t address) {
    return fmt::format(
        R"(<IntReg Name="{}" NameSpace="Custom"><Address>{:#x}</Address><Length>4</Length>
<AccessMode>RW</AccessMode><pPort>Device</pPort><Cachable>NoCache</Cachable><Sign>Unsigned</Sign><Endianess>BigEndian</Endianess></IntReg>
)",
        name, address);
  };
  const auto chunk_value = [](const char* name, const char* type, std::uint32_t id) {
    const bool integer = std::string(type) == "IntReg";
    return fmt::format(
        R"(<{0} Name="{1}" NameSpace="Standard"><Address>0</Address><Length>8</Length><AccessMode>RO</AccessMode>
<pPort>Pvcap{1}Port</pPort><Cachable>NoCache</Cachable>{3}<Endianess>BigEndian</Endianess></{0}>
<Port Name="Pvcap{1}Port" NameSpace="Custom"><ChunkID>{2:08X}</ChunkID></Port>
)",
        type, name, id, integer ? "<Sign>Unsigned</Sign>" : "");
  };
  std::string chunks =
      R"(<Boolean Name="ChunkModeActive" NameSpace="Standard"><pValue>PvcapChunkModeRegister</pValue></Boolean>
<Enumeration Name="ChunkSelector" NameSpace="Standard">
<EnumEntry Name="FrameID"><Value>0</Value></EnumEntry><EnumEntry Name="Timestamp"><Value>1</Value></EnumEntry>
<EnumEntry Name="ExposureTime"><Value>2</Value></EnumEntry><EnumEntry Name="Gain"><Value>3</Value></EnumEntry>
<EnumEntry Name="LineStatusAll"><Value>4</Value></EnumEntry>
<pValue>PvcapChunkSelectorRegister</pValue></Enumeration>
<Boolean Name="ChunkEnable" NameSpace="Standard"><pValue>PvcapChunkEnableRegister</pValue></Boolean>
)";
  chunks += int_register("PvcapChunkModeRegister", kChunkModeRegister);
  chunks += int_register("PvcapChunkSelectorRegister", kChunkSelectorRegister);
  chunks += int_register("PvcapChunkEnableRegister", kChunkEnableRegister);
  chunks += chunk_value("ChunkFrameID", "IntReg", kFrameIdChunkId);
  chunks += chunk_value("ChunkTimestamp", "IntReg", kTimestampChunkId);
  chunks += chunk_value("ChunkExposureTime", "FloatReg", kExposureTimeChunkId);
  chunks += chunk_value("ChunkGain", "FloatReg", kGainChunkId);
  chunks += chunk_value("ChunkLineStatusAll", "IntReg", kLineStatusChunkId);
  text.insert(text.rfind("</RegisterDescription>"), chunks);
  const std::string payload = "<Formula>WIDTH * HEIGHT * ((PIXELFORMAT>>16)&amp;0xFF) / 8</Formula>";
  const auto at = text.find(payload);
  if (at == std::string::npos) return "";  // another Aravis' map: say so by failing, not by a wrong payload
  text.replace(at, payload.size(),
               fmt::format("<pVariable Name=\"CHUNKS\">PvcapChunkModeRegister</pVariable>\n"
                           "<Formula>WIDTH * HEIGHT * ((PIXELFORMAT>>16)&amp;0xFF) / 8 + CHUNKS * {}</Formula>",
                           kChunkBytes));
  return text;
}
// Aravis' names, with the exposure only in the camera's own steps, as a Basler ace classic or an
// older Allied Vision declares it: ExposureTimeRaw counts steps of ExposureTimeBaseAbs (20 us here),
// on the engine's microsecond register (its ExposureTimeAbs hidden under a name of ours).
std::string raw_exposure_map() {
  std::string text = aravis_map_with_features("TimestampControlLatch");
  if (text.empty()) return text;
  replace_all(text, "ExposureTimeAbs", "PvcapExposureTimeUs");
  replace_all(text, "ModelName=\"Fake\"", "ModelName=\"Fake raw exposure\"");
  const std::string features = fmt::format(
      R"(<Integer Name="ExposureTimeRaw" NameSpace="Standard"><ToolTip>Exposure = raw x ExposureTimeBaseAbs</ToolTip>
<pValue>PvcapExposureRawConverter</pValue><Min>1</Min><Max>500000</Max></Integer>
<IntConverter Name="PvcapExposureRawConverter" NameSpace="Custom"><pVariable Name="BASE">ExposureTimeBaseAbs</pVariable>
<FormulaTo>FROM * BASE</FormulaTo><FormulaFrom>TO / BASE</FormulaFrom><pValue>PvcapExposureTimeUsRegister</pValue></IntConverter>
<Float Name="ExposureTimeBaseAbs" NameSpace="Standard"><ToolTip>One step of ExposureTimeRaw, in us</ToolTip>
<Value>{:.1f}</Value><Unit>us</Unit></Float>
)",
      kRawExposureStepUs);
  text.insert(text.rfind("</RegisterDescription>"), features);
  return text;
}
}  // namespace

std::string fake_camera_genicam(NodeMapNaming naming) {
  static std::once_flag once;
  static std::string aravis_path, sfnc2_path, raw_path;
  std::call_once(once, [] {
    if (const std::string text = aravis_map_with_features("TimestampControlLatch"); !text.empty())
      aravis_path = write_by_content(text);
    if (const std::string text = sfnc2_map(); !text.empty()) sfnc2_path = write_by_content(text);
    if (const std::string text = raw_exposure_map(); !text.empty()) raw_path = write_by_content(text);
  });
  return naming == NodeMapNaming::Sfnc2 ? sfnc2_path : naming == NodeMapNaming::RawExposure ? raw_path : aravis_path;
}

namespace {
// One thread serves the latch and trigger line of every simulated camera in the process (a
// thread per camera polling this often would take a good part of a core from the simulators).
class FeatureService {
 public:
  static FeatureService& get() {
    static FeatureService service;
    return service;
  }
  void add(const void* owner, ArvFakeCamera* fake, DeviceClock clock, TriggerLine line, NodeMapNaming naming,
           OutputLines outputs, PtpBehaviour ptp) {
    // The engine triggers on a pending software trigger; which source the host chose is ours.
    arv_fake_camera_write_register(fake, kEngineTriggerSource, kSoftware);
    std::lock_guard lock(mu_);
    cameras_.push_back({owner, fake, std::move(clock), std::move(line), INT64_MIN, naming == NodeMapNaming::Sfnc2,
                        host_now().ns, std::move(outputs), 0, ptp, -1, false, 0,
                        std::mt19937_64(std::uint64_t(reinterpret_cast<std::uintptr_t>(owner)))});
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
  }
  void remove(const void* owner) {
    std::lock_guard lock(mu_);
    cameras_.erase(std::remove_if(cameras_.begin(), cameras_.end(), [&](const Camera& c) { return c.owner == owner; }),
                   cameras_.end());
  }
  ~FeatureService() {
    running_.store(false);
    if (thread_.joinable()) thread_.join();
  }

 private:
  // The fake engine's registers (arvfakecamera.h).
  static constexpr std::uint32_t kEngineTriggerMode = 0x300, kEngineTriggerSource = 0x304,
                                 kEngineTriggerSoftware = 0x30c, kEngineFramePeriod = 0x138, kSoftware = 1;
  struct Camera {
    const void* owner;
    ArvFakeCamera* fake;
    DeviceClock clock;
    TriggerLine line;
    std::int64_t last_pulse;  // the line's last pulse that reached this camera (its index)
    bool gated_rate;          // SFNC 2 map: the rate takes only with its enable on
    std::int64_t served_ns;   // when it was first served: its temperature rises from then
    OutputLines outputs;      // told of each change of its output lines
    std::uint32_t output_mask;
    PtpBehaviour ptp;
    std::int64_t ptp_enabled_ns;  // when PtpEnable was set (-1: off)
    bool ptp_locked;              // as last served
    std::uint32_t ptp_status;     // PtpStatus as last written (0: Disabled, the registers' start)
    std::mt19937_64 rng;          // the servo's error
  };
  // When the host has set the command register, the device clock's value goes into the value
  // register and the command clears.
  static void serve_latch(const Camera& c) {
    guint32 command = 0;
    if (!arv_fake_camera_read_register(c.fake, kLatchCommandRegister, &command) || command == 0) return;
    const auto device = std::uint64_t(std::max<std::int64_t>(0, c.clock(host_now().ns)));
    arv_fake_camera_write_register(c.fake, kLatchValueRegister, guint32(device >> 32));
    arv_fake_camera_write_register(c.fake, kLatchValueRegister + 4, guint32(device & 0xFFFFFFFFu));
    arv_fake_camera_write_register(c.fake, kLatchCommandRegister, 0);
  }
  // At each new pulse of the line, a camera triggered by it (TriggerMode On, source Line0) is
  // triggered as the engine understands it (a trigger pending until it acquires).
  static void serve_line(Camera& c, std::int64_t now_ns) {
    if (!c.line) return;
    guint32 mode = 0, source = 0;
    if (!arv_fake_camera_read_register(c.fake, kEngineTriggerMode, &mode) || mode != 1) return;
    if (!arv_fake_camera_read_register(c.fake, kTriggerSourceRegister, &source) || source == kSoftware) return;
    const std::int64_t pulse = c.line(now_ns);
    if (pulse <= c.last_pulse) return;
    c.last_pulse = pulse;
    arv_fake_camera_write_register(c.fake, kEngineTriggerSoftware, 1);
  }
  // Enabled, the rate asked goes to the engine; disabled, the engine's own rate is what reads back.
  static void serve_rate(const Camera& c) {
    if (!c.gated_rate) return;
    guint32 enabled = 0, asked = 0, engine = 0;
    if (!arv_fake_camera_read_register(c.fake, kFrameRateEnableRegister, &enabled) ||
        !arv_fake_camera_read_register(c.fake, kFramePeriodRegister, &asked) ||
        !arv_fake_camera_read_register(c.fake, kEngineFramePeriod, &engine))
      return;
    if (enabled && asked != 0 && asked != engine) arv_fake_camera_write_register(c.fake, kEngineFramePeriod, asked);
    if (!enabled && asked != engine) arv_fake_camera_write_register(c.fake, kFramePeriodRegister, engine);
  }
  // The SFNC 2 map's DeviceTemperature: a camera warming up, 0.5 C a second from 40 C.
  static void serve_temperature(const Camera& c, std::int64_t now_ns) {
    if (!c.gated_rate) return;
    arv_fake_camera_write_register(c.fake, kDeviceTemperatureRegister,
                                   guint32(400 + (now_ns - c.served_ns) / 200'000'000));
  }
  // Each line's level from its source: off, high while acquiring (ExposureActive: a strobe that the
  // simulated lamp shows as lit while the camera streams), or the selected user output's value; kept
  // in the line-status register (each frame's chunk reads it) and told to the lamps.
  static void serve_outputs(Camera& c, std::int64_t now_ns) {
    if (!c.outputs && !c.gated_rate) return;  // no lamps, and no line-status chunk (SFNC 2 map only)
    guint32 acquiring = 0;
    arv_fake_camera_read_register(c.fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION, &acquiring);
    std::uint32_t mask = 0;
    for (int line = 0; line < kOutputLines; ++line) {
      guint32 source = 0, value = 0;
      if (!arv_fake_camera_read_register(c.fake, kLineSourceRegister + 4 * std::uint32_t(line), &source)) continue;
      bool high = source == 1 && acquiring;
      if (source >= 2 && source < 2 + kUserOutputs &&
          arv_fake_camera_read_register(c.fake, kUserOutputValueRegister + 4 * (source - 2), &value))
        high = value != 0;
      if (high) mask |= 1u << line;
    }
    if (mask == c.output_mask) return;
    c.output_mask = mask;
    arv_fake_camera_write_register(c.fake, kLineStatusRegister, mask);
    if (c.outputs) c.outputs(mask, now_ns);
  }
  // The SFNC 2 map's PTP: listening from PtpEnable for lock_after_s, then a locked slave (but for its
  // unlock window: uncalibrated, the servo unknown); PtpDataSetLatch latches an offset from the
  // master, the servo's error drawn each time (microseconds while it is not locked).
  static void serve_ptp(Camera& c, std::int64_t now_ns) {
    if (!c.gated_rate) return;
    guint32 enabled = 0;
    if (!arv_fake_camera_read_register(c.fake, kPtpEnableRegister, &enabled)) return;
    if (!enabled) {
      if (c.ptp_enabled_ns >= 0) {  // switched off: Disabled, the servo unknown
        arv_fake_camera_write_register(c.fake, kPtpStatusRegister, 0);
        arv_fake_camera_write_register(c.fake, kPtpServoRegister, 0);
      }
      c.ptp_enabled_ns = -1;
      c.ptp_status = 0;
      return;
    }
    if (c.ptp_enabled_ns < 0) c.ptp_enabled_ns = now_ns;
    const double on_s = double(now_ns - c.ptp_enabled_ns) / 1e9;
    const bool unlocked = c.ptp.unlock_at_s && on_s >= *c.ptp.unlock_at_s && on_s < *c.ptp.unlock_at_s + c.ptp.unlock_for_s;
    const bool locked = on_s >= c.ptp.lock_after_s && !unlocked;
    if (const std::uint32_t status = locked ? 4 : unlocked ? 3 : 2; status != c.ptp_status) {  // as it changes
      c.ptp_status = status;
      arv_fake_camera_write_register(c.fake, kPtpStatusRegister, status);
      arv_fake_camera_write_register(c.fake, kPtpServoRegister, locked ? 1 : 0);
    }
    // A latch is served up to 200 us after the host's command, which the host may read before: the
    // offset is drawn again at each change of lock too, so what it reads is of the state it reads.
    guint32 latch = 0;
    const bool latched = arv_fake_camera_read_register(c.fake, kPtpLatchRegister, &latch) && latch != 0;
    if (!latched && locked == c.ptp_locked) return;
    c.ptp_locked = locked;
    std::normal_distribution<double> error(0.0, locked ? c.ptp.servo_error_ns : 20'000.0);
    const double offset = std::clamp(error(c.rng), -2e9, 2e9);
    arv_fake_camera_write_register(c.fake, kPtpOffsetRegister, guint32(std::int32_t(std::lround(offset))));
    if (latched) arv_fake_camera_write_register(c.fake, kPtpLatchRegister, 0);
  }
  void run() {
    // A camera's latch and trigger input are its hardware's; here a thread serves them every 200 us,
    // 3,000-5,000 wake-ups a second. In the fair scheduler, on saturated cores, the kernel worker
    // that carries a pseudo-terminal's bytes (the simulated Morph's) was traced waiting 107 ms behind
    // it and a busy loop (4 of 24 sessions lost pressure samples so, 0 of 24 with a 1 ms poll;
    // docs/testing.md, "How the suite is scheduled"). At a real-time priority, where allowed, it
    // leaves the fair scheduler to the threads that share it.
    {
      sched_param rt{};
      rt.sched_priority = 5;
      (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &rt);
    }
    while (running_.load()) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      const std::int64_t now = host_now().ns;
      std::lock_guard lock(mu_);
      for (Camera& c : cameras_) {
        serve_latch(c);
        serve_line(c, now);
        serve_rate(c);
        serve_temperature(c, now);
        serve_outputs(c, now);
        serve_ptp(c, now);
      }
    }
  }
  std::mutex mu_;
  std::vector<Camera> cameras_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};
}  // namespace

TriggerLine periodic_line(double hz) {
  return [hz](std::int64_t host_ns) { return std::int64_t(double(host_ns) * hz / 1e9); };
}

void serve_features(const void* owner, ArvFakeCamera* fake, DeviceClock clock, TriggerLine line, NodeMapNaming naming,
                    OutputLines outputs, PtpBehaviour ptp) {
  FeatureService::get().add(owner, fake, std::move(clock), std::move(line), naming, std::move(outputs), ptp);
}
void stop_serving(const void* owner) { FeatureService::get().remove(owner); }

}  // namespace pvcap::sim
