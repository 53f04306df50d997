#include "capture/genicam_features.h"

#include <utility>

namespace pvcap {

const std::vector<RoleNames>& camera_feature_names() {
  static const std::vector<RoleNames> table = {
      {CameraRole::AcquisitionMode, "acquisition_mode", {"AcquisitionMode"}},
      {CameraRole::PixelFormat, "pixel_format", {"PixelFormat"}},
      {CameraRole::Width, "width", {"Width"}},
      {CameraRole::Height, "height", {"Height"}},
      {CameraRole::OffsetX, "offset_x", {"OffsetX"}},
      {CameraRole::OffsetY, "offset_y", {"OffsetY"}},
      {CameraRole::TriggerSelector, "trigger_selector", {"TriggerSelector"}},
      {CameraRole::TriggerMode, "trigger_mode", {"TriggerMode"}},
      {CameraRole::TriggerSource, "trigger_source", {"TriggerSource"}},
      {CameraRole::TriggerActivation, "trigger_activation", {"TriggerActivation"}},
      // SFNC 2; Basler ace classic and Allied Vision: ...Abs.
      {CameraRole::FrameRate, "frame_rate", {"AcquisitionFrameRate", "AcquisitionFrameRateAbs"}},
      // FLIR needs it set before a rate takes; older Point Grey spell it with a d.
      // ...and Daheng's is an enumeration (On/Off).
      {CameraRole::FrameRateEnable,
       "frame_rate_enable",
       {"AcquisitionFrameRateEnable", "AcquisitionFrameRateEnabled", "AcquisitionFrameRateMode"}},
      // The rate it will reach as configured (region, format, exposure): FLIR and SFNC 2, Basler ace 2; ace classic.
      {CameraRole::ResultingFrameRate,
       "resulting_frame_rate",
       {"AcquisitionResultingFrameRate", "ResultingFrameRate", "ResultingFrameRateAbs"}},
      {CameraRole::ExposureTime, "exposure_time", {"ExposureTime", "ExposureTimeAbs", "ExposureTimeRaw"}},
      {CameraRole::ExposureAuto, "exposure_auto", {"ExposureAuto"}},
      {CameraRole::Gain, "gain", {"Gain", "GainAbs", "GainRaw"}},
      {CameraRole::GainAuto, "gain_auto", {"GainAuto"}},
      {CameraRole::BalanceWhiteAuto, "balance_white_auto", {"BalanceWhiteAuto"}},
      {CameraRole::PacketSize, "packet_size", {"GevSCPSPacketSize"}},
      // Inter-packet delay on most; Allied Vision limits bytes per second instead.
      {CameraRole::BandwidthLimit, "bandwidth_limit", {"GevSCPD", "StreamBytesPerSecond", "DeviceLinkThroughputLimit"}},
      // SFNC: DeviceLinkThroughputLimit takes only with its mode On.
      {CameraRole::BandwidthLimitMode, "bandwidth_limit_mode", {"DeviceLinkThroughputLimitMode"}},
      {CameraRole::TimestampLatch,
       "timestamp_latch",
       {"TimestampLatch", "GevTimestampControlLatch", "TimestampControlLatch", "timestampControlLatch"}},
      {CameraRole::TimestampLatchValue,
       "timestamp_latch_value",
       {"TimestampLatchValue", "GevTimestampValue", "TimestampValue", "timestampValue"}},
      // Absent on SFNC 2 cameras, whose timestamps count nanoseconds.
      {CameraRole::TimestampTickFrequency,
       "timestamp_tick_frequency",
       {"GevTimestampTickFrequency", "TimestampTickFrequency"}},
      // Basler ace 2: PtpEnable; FLIR, Basler ace classic: GevIEEE1588; Allied Vision: PtpMode (an
      // enumeration: Off, Slave, Master, Auto).
      {CameraRole::PtpEnable, "ptp_enable", {"PtpEnable", "GevIEEE1588", "PtpMode"}},
      {CameraRole::PtpStatus, "ptp_status", {"PtpStatus", "GevIEEE1588Status"}},
      // Basler ace 2; FLIR Blackfly S: latches the data set the offset below is read from.
      {CameraRole::PtpDataSetLatch, "ptp_data_set_latch", {"PtpDataSetLatch", "GevIEEE1588DataSetLatch"}},
      {CameraRole::PtpOffsetFromMaster,
       "ptp_offset_from_master",
       {"PtpOffsetFromMaster", "GevIEEE1588OffsetFromMasterLatched"}},
      // Basler ace 2: whether its clock servo has locked (Allied Vision's PtpSyncLocked is an event).
      {CameraRole::PtpServoStatus, "ptp_servo_status", {"PtpServoStatus"}},
      {CameraRole::ChunkModeActive, "chunk_mode_active", {"ChunkModeActive"}},
      {CameraRole::ChunkSelector, "chunk_selector", {"ChunkSelector"}},
      {CameraRole::ChunkEnable, "chunk_enable", {"ChunkEnable"}},
      // SFNC 2 (Basler ace 2, FLIR Blackfly S, Oryx); Basler ace classic; Point Grey.
      {CameraRole::ChunkFrameCounter,
       "chunk_frame_counter",
       {"ChunkFrameID", "ChunkFramecounter", "ChunkFrameCounter"}},
      {CameraRole::ChunkTimestamp, "chunk_timestamp", {"ChunkTimestamp"}},
      {CameraRole::ChunkExposureTime, "chunk_exposure_time", {"ChunkExposureTime"}},
      // Basler ace classic: the gain of all channels.
      {CameraRole::ChunkGain, "chunk_gain", {"ChunkGain", "ChunkGainAll"}},
      // Basler ace 2 and ace classic; FLIR Blackfly S (the lines' levels at the exposure's end).
      {CameraRole::ChunkLineStatus, "chunk_line_status", {"ChunkLineStatusAll", "ChunkExposureEndLineStatusAll"}},
      {CameraRole::ActionSelector, "action_selector", {"ActionSelector"}},
      {CameraRole::ActionDeviceKey, "action_device_key", {"ActionDeviceKey"}},
      {CameraRole::ActionGroupKey, "action_group_key", {"ActionGroupKey"}},
      {CameraRole::ActionGroupMask, "action_group_mask", {"ActionGroupMask"}},
      // SFNC (Basler, FLIR, Point Grey); Allied Vision's SyncOut, whose levels are a bit per output.
      {CameraRole::LineSelector, "line_selector", {"LineSelector", "SyncOutSelector"}},
      {CameraRole::LineSource, "line_source", {"LineSource", "SyncOutSource"}},
      {CameraRole::UserOutputSelector, "user_output_selector", {"UserOutputSelector"}},
      {CameraRole::UserOutputValue, "user_output_value", {"UserOutputValue", "SyncOutLevels", "SyncOutGpoLevels"}},
      {CameraRole::DeviceTemperature, "device_temperature", {"DeviceTemperature", "TemperatureAbs"}},
      {CameraRole::FirmwareVersion, "firmware_version", {"DeviceFirmwareVersion", "DeviceVersion"}},
  };
  return table;
}

const char* role_key(CameraRole role) {
  for (const auto& r : camera_feature_names())
    if (r.role == role) return r.key;
  return "";
}

const RawUnit* raw_unit(const std::string& feature) {
  static const RawUnit kRaw[] = {
      {"ExposureTimeRaw", "ExposureTimeBaseAbs", "us"},
      {"GainRaw", nullptr, "GainRaw counts"},
      {"ChunkGainAll", nullptr, "GainRaw counts"},  // Basler ace classic: each frame's GainRaw
  };
  for (const RawUnit& r : kRaw)
    if (feature == r.feature) return &r;
  return nullptr;
}

std::string role_unit(CameraRole role, const std::string& feature) {
  if (const RawUnit* raw = raw_unit(feature)) return raw->unit;
  if (role == CameraRole::ExposureTime || role == CameraRole::ChunkExposureTime) return "us";
  if (role == CameraRole::Gain || role == CameraRole::ChunkGain) return "dB";  // SFNC's Gain, GainAbs, ChunkGain
  return "";
}

std::map<CameraRole, std::string> resolve_camera_features(const std::function<bool(const std::string&)>& has) {
  std::map<CameraRole, std::string> out;
  for (const auto& r : camera_feature_names()) {
    if (r.role == CameraRole::TimestampLatch || r.role == CameraRole::TimestampLatchValue) continue;
    for (const char* name : r.names)
      if (const RawUnit* raw = raw_unit(name); raw && raw->base && !has(raw->base)) {
        continue;  // its counts without their size
      } else if (has(name)) {
        out[r.role] = name;
        break;
      }
  }
  // The latch command and the register it fills, one naming family at a time.
  static const std::pair<const char*, const char*> kLatchFamilies[] = {
      {"TimestampLatch", "TimestampLatchValue"},          // SFNC 2 (FLIR Blackfly S, Oryx; Basler ace 2)
      {"GevTimestampControlLatch", "GevTimestampValue"},  // GigE Vision SFNC 1 (Basler ace, AVT, Point Grey)
      {"TimestampControlLatch", "TimestampLatchValue"},   // Aravis' fake camera
      {"TimestampControlLatch", "TimestampValue"},        // SFNC 1.x without the Gev prefix
      {"timestampControlLatch", "timestampValue"},        // Teledyne DALSA (its own lower-case names)
  };
  for (const auto& [latch, value] : kLatchFamilies)
    if (has(latch) && has(value)) {
      out[CameraRole::TimestampLatch] = latch;
      out[CameraRole::TimestampLatchValue] = value;
      break;
    }
  return out;
}

}  // namespace pvcap
