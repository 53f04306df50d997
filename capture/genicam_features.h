#pragma once
// Which GenICam feature plays each role pvcap needs of a camera, under the names real cameras' node
// maps use (SFNC 2 and its older forms, and vendors' own: ../shared/data/genicam/README.md). The one
// table of names: the live camera (capture/aravis_camera.cpp) and the offline check (`pvcap camera
// check`) both ask it, each with its own way to tell whether a feature exists. Pure: no Aravis.
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/rig_config.h"  // line_number

namespace pvcap {

enum class CameraRole {
  AcquisitionMode,
  PixelFormat,
  Width,
  Height,
  OffsetX,
  OffsetY,
  TriggerSelector,
  TriggerMode,
  TriggerSource,
  TriggerActivation,
  FrameRate,
  FrameRateEnable,
  ResultingFrameRate,
  ExposureTime,
  ExposureAuto,
  Gain,
  GainAuto,
  BalanceWhiteAuto,
  PacketSize,
  BandwidthLimit,
  BandwidthLimitMode,
  TimestampLatch,
  TimestampLatchValue,
  TimestampTickFrequency,
  PtpEnable,
  PtpStatus,
  PtpDataSetLatch,
  PtpOffsetFromMaster,
  PtpServoStatus,
  ChunkModeActive,
  ChunkSelector,
  ChunkEnable,
  // Each frame's own state, read from its chunk data (the selector's entry is the name without "Chunk").
  ChunkFrameCounter,
  ChunkTimestamp,
  ChunkExposureTime,
  ChunkGain,
  // Every line's level as the frame was taken, a bit per line (bit N: LineN).
  ChunkLineStatus,
  // Scheduled action commands (GigE Vision 2.0 ACTION_CMD): the keys a camera answers to.
  ActionSelector,
  ActionDeviceKey,
  ActionGroupKey,
  ActionGroupMask,
  // Output lines (a light switched by the camera): SFNC's line and user output, Allied Vision's SyncOut.
  LineSelector,
  LineSource,
  UserOutputSelector,
  UserOutputValue,
  DeviceTemperature,
  FirmwareVersion,
};

struct RoleNames {
  CameraRole role;
  const char* key;                 // "timestamp_latch": how the check's report names the role
  std::vector<const char*> names;  // in the order they are tried
};
// Every role with its names.
const std::vector<RoleNames>& camera_feature_names();
const char* role_key(CameraRole role);

// A feature that counts in the camera's own steps, and the feature giving one step's size in
// pvcap's unit: ExposureTimeRaw x ExposureTimeBaseAbs (us), as Basler's ace classic and older Allied
// Vision maps define it. Gain has no standard step: GainRaw is kept in its counts, and said so.
struct RawUnit {
  const char* feature;  // "ExposureTimeRaw"
  const char* base;     // "ExposureTimeBaseAbs" (a Float in `unit` per count), or nullptr: no conversion
  const char* unit;     // the unit after conversion ("us"), or the counts' own name ("GainRaw counts")
};
// nullptr when `feature` is not one of the camera's own counts.
const RawUnit* raw_unit(const std::string& feature);
// The unit in which pvcap reads and writes `role` through `feature` (its chosen name): "us" for an
// exposure (converted where it is raw), "dB" for Gain and GainAbs, "GainRaw counts" for GainRaw, ""
// for every role without one.
std::string role_unit(CameraRole role, const std::string& feature);

// The feature chosen for each role a camera has; `has(name)` says whether the camera's node map has
// a feature of that name. The latch and its value are chosen as a pair of one naming family
// (`TimestampLatch` + `TimestampLatchValue`, `GevTimestampControlLatch` + `GevTimestampValue`, ...):
// a latch without its value reads nothing. A raw feature with a base (ExposureTimeRaw) is chosen only
// with its base: a count pvcap cannot convert is never taken for microseconds.
std::map<CameraRole, std::string> resolve_camera_features(const std::function<bool(const std::string&)>& has);

}  // namespace pvcap
