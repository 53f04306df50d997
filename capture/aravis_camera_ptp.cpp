// AravisCamera's PTP (rig file `ptp:` with cameras: docs/multihost.md): enabled through its map's
// own names (capture/genicam_features.h: ptp_enable, a Boolean on Basler ace 2 and FLIR, an
// enumeration on Allied Vision), then its state read (ptp_status, ptp_servo_status, and the offset
// from its master after latching its data set): before the session, until it has locked, and once
// a second while it records, from the probe thread (never the capture thread).
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "capture/aravis_camera.h"
#include "capture/aravis_camera_link.h"
#include "capture/aravis_features.h"
#include "capture/genicam_features.h"

namespace pvcap {

bool CameraPtpState::locked() const {
  const bool following = status == "Slave" || status == "Master";
  return following && (!servo || *servo == "Locked");
}

std::string CameraPtpState::json() const {
  nlohmann::json j = {{"status", status}, {"locked", locked()}};
  j["servo"] = servo ? nlohmann::json(*servo) : nlohmann::json(nullptr);
  j["offset_ns"] = offset_ns ? nlohmann::json(*offset_ns) : nlohmann::json(nullptr);
  return j.dump();
}

std::string CameraPtpState::describe() const {
  std::string out = status;
  if (servo) out += ", servo " + *servo;
  if (offset_ns) out += fmt::format(", offset {} ns", *offset_ns);
  return out;
}

Status AravisCamera::enable_ptp(AravisFeatures& f) {
  if (!f.has(CameraRole::PtpEnable))
    return Error{fmt::format("{}: has no PTP feature (PtpEnable, GevIEEE1588 or PtpMode): record it without PTP "
                             "(the rig file's ptp: cameras: false), or on a camera that keeps PTP time",
                             label())};
  // Allied Vision's PtpMode is an enumeration (Off, Slave, Master, Auto): a camera follows.
  const Status s = f.name(CameraRole::PtpEnable) == "PtpMode" ? f.set_entry(CameraRole::PtpEnable, "Slave")
                                                               : f.set_flag(CameraRole::PtpEnable, true);
  return setting(s, "PTP on");
}

Result<CameraPtpState> AravisCamera::read_ptp(AravisFeatures& f) {
  if (!f.has(CameraRole::PtpStatus))
    return Error{fmt::format("{}: has no PTP status feature (PtpStatus, GevIEEE1588Status)", label())};
  CameraPtpState s;
  // The offset first: the latch also freezes the status where the camera latches both (FLIR).
  if (f.has(CameraRole::PtpDataSetLatch) && f.has(CameraRole::PtpOffsetFromMaster)) {
    if (Status latched = f.execute(CameraRole::PtpDataSetLatch); !latched.ok()) return latched.error();
    if (const auto o = f.number(CameraRole::PtpOffsetFromMaster)) s.offset_ns = std::int64_t(std::llround(*o));
  }
  const auto status = f.entry(CameraRole::PtpStatus);
  if (!status) return Error{fmt::format("{}: its {} cannot be read", label(), f.name(CameraRole::PtpStatus))};
  s.status = *status;
  if (f.has(CameraRole::PtpServoStatus)) s.servo = f.entry(CameraRole::PtpServoStatus);
  return s;
}

Result<CameraPtpState> AravisCamera::read_ptp() {
  arv::GPtr<ArvCamera> cam;
  {
    std::lock_guard lock(mu_);
    if (!link_->camera) return Error{fmt::format("{}: not connected: its PTP state cannot be read", label())};
    cam.reset(ARV_CAMERA(g_object_ref(link_->camera.get())));
  }
  AravisFeatures f(arv_camera_get_device(cam.get()));
  return read_ptp(f);
}

void AravisCamera::watch_ptp(AravisFeatures& f) {
  const auto s = read_ptp(f);
  std::optional<std::string> problem;
  if (!s)
    problem = s.error().message;
  else {
    emit(CameraEvent::Kind::PtpReading, s.value().json());
    if (!s.value().locked())
      problem = fmt::format("{}: PTP not locked: {}", label(), s.value().describe());
  }
  if (problem) {
    emit(CameraEvent::Kind::PtpOutOfLock, *problem);
    if (!ptp_out_of_lock_)
      emit(CameraEvent::Kind::State, *problem + " (named each second it lasts, in the session's events)");
  } else if (ptp_out_of_lock_) {
    emit(CameraEvent::Kind::State, fmt::format("{}: PTP locked again: {}", label(), s.value().describe()));
  }
  ptp_out_of_lock_ = bool(problem);
}

}  // namespace pvcap
