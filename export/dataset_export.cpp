#include "export/dataset_export.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "calib/projection.h"
#include "calib/recorded_calibration.h"
#include "codec/sensel_units.h"
#include "core/durable_folder.h"
#include "export/jpeg_lanes.h"
#include "export/numpy_files.h"
#include "export/pv_geometry.h"
#include "export/sha256.h"
#include "protocol/takes.h"
#include "storage/index/session_reader.h"

namespace pvcap::exporting {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// kPa = counts / 2.7125 in the loaders (1736 counts per newton on a 1.25 mm cell).
constexpr double kLoaderCountsPerKpa = 1736.0 * 1.25e-3 * 1.25e-3 * 1000.0;

// A name a folder of the export is made from (a pseudonym, a take, a mapped folder), as it comes
// from a store or an output folder that may have been crafted: letters, digits and - _ ( ) only,
// at most 100, so no name can leave --out or hide as a dot file.
bool safe_name(const std::string& s) {
  if (s.empty() || s.size() > 100) return false;
  for (const char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '(' && c != ')') return false;
  return true;
}

// The output folder's participant mapping, read and extended under an exclusive lock, so parallel
// jobs exporting the same participant agree on one folder.
Result<std::string> participant_folder(const fs::path& out, const std::string& pseudonym) {
  const fs::path lock_path = out / "participants.lock";
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return Error{fmt::format("{}: cannot be opened: {}", lock_path.string(), std::strerror(errno))};
  struct Unlock {
    int fd;
    ~Unlock() { ::close(fd); }  // closing drops the lock
  } unlock{fd};
  if (flock(fd, LOCK_EX) != 0)
    return Error{fmt::format("{}: cannot be locked: {}", lock_path.string(), std::strerror(errno))};
  const fs::path map_path = out / "participants.json";
  json map = json::object();
  if (fs::exists(map_path)) {
    std::ifstream in(map_path);
    map = json::parse(in, nullptr, false);
    if (!map.is_object())
      return Error{fmt::format("{}: is not the participant mapping pvcap writes (a JSON object); move it away",
                               map_path.string())};
  }
  if (map.contains(pseudonym) && map[pseudonym].is_string()) {
    const std::string folder = map[pseudonym].get<std::string>();
    if (!safe_name(folder))
      return Error{
          fmt::format("{}: the folder '{}' it gives participant '{}' is not a folder name pvcap makes; "
                      "move the file away",
                      map_path.string(), folder, pseudonym)};
    return folder;
  }
  int next = 1;
  for (const auto& [code, folder] : map.items())
    if (folder.is_string()) next = std::max(next, std::atoi(folder.get<std::string>().substr(0, 4).c_str()) + 1);
  if (next > 9999) return Error{fmt::format("{}: no 4-digit participant id left", map_path.string())};
  const std::string folder = fmt::format("{:04d}_{}", next, pseudonym);
  map[pseudonym] = folder;
  if (auto w = write_file_atomically(map_path, map.dump(2) + "\n", Durability::Renamed); !w.ok()) return w.error();
  return folder;
}

json matrix(const cv::Matx44d& m) {
  json out = json::array();
  for (int r = 0; r < 4; ++r) out.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return out;
}

json matrix(const cv::Matx33d& m) {
  json out = json::array();
  for (int r = 0; r < 3; ++r) out.push_back({m(r, 0), m(r, 1), m(r, 2)});
  return out;
}

// The sample's pressure in the loaders' units, on the 185 x 105 sensel grid (rows x cols: 105 x 185).
Result<cv::Mat> loader_force(SessionReader& r, const SampleInfo::PressureRef& ref) {
  auto p = r.pressure_frame(ref.sequence, ref.connection);
  if (!p) return p.error();
  const PressureFrame& f = p.value();
  const sensel::Grid grid{f.grid_cols, f.grid_rows, f.grid_xscale, f.grid_yscale};
  const std::vector<float> up = sensel::upsample(f.counts, grid);
  cv::Mat out(grid.out_rows(), grid.out_cols(), CV_32F);
  for (std::size_t i = 0; i < up.size(); ++i)
    out.at<float>(int(i)) = float(sensel::upsampled_sensel_kpa(up[i], grid) * kLoaderCountsPerKpa);
  return out;
}

struct PlannedSequence {
  const protocol::TakeRow* take = nullptr;
  std::string folder;
  std::vector<std::size_t> samples;  // kept samples, in order
  std::size_t left_out = 0;
};

}  // namespace

std::string light_direction_words(const std::string& lighting) {
  // A code of L, C, R (and '-' for a light off) becomes words; anything else is passed on as the
  // lab wrote it (the loaders look for the words left, center, right in it).
  const bool code = !lighting.empty() && lighting.find_first_not_of("LCRlcr-") == std::string::npos;
  if (!code) return lighting.empty() ? "unrecorded" : lighting;
  std::string out;
  for (char c : lighting) {
    const char* word = c == 'L' || c == 'l'   ? "left"
                       : c == 'C' || c == 'c' ? "center"
                       : c == 'R' || c == 'r' ? "right"
                                              : nullptr;
    if (word) out += (out.empty() ? "" : " ") + std::string(word);
  }
  return out.empty() ? "none" : out;
}

namespace {

// One session's export, step by step: validate, geometry, select, folders, then each sequence's
// frames and force, manifest and metadata.
class SessionExport {
 public:
  SessionExport(const fs::path& session, const ExportOptions& o, const std::atomic<bool>& stop)
      : session_(session), o_(o), stop_(stop), here_(fs::absolute(session).lexically_normal().string()) {}

  Result<ExportResult> run() {
    for (Status (SessionExport::*step)() :
         {&SessionExport::validate, &SessionExport::geometry, &SessionExport::select, &SessionExport::folders})
      if (Status s = (this->*step)(); !s.ok()) return s.error();
    for (const auto& p : plan_) {
      if (Status s = write_sequence(p); !s.ok()) return s.error();
      if (result_.interrupted) break;
    }
    return result_;
  }

 private:
  Status validate() {
    auto opened = SessionReader::open(session_);
    if (!opened) return opened.error();
    reader_ = std::move(opened.value());
    if (!reader_->pressure_device())
      return Error{fmt::format("{}: the session has no pressure frames; the layout needs force for every frame",
                               session_.string())};
    if (o_.jpeg_quality < 1 || o_.jpeg_quality > 100)
      return Error{fmt::format("--jpeg-quality {} is not in 1..100", o_.jpeg_quality)};
    cameras_ = o_.cameras;
    if (cameras_.empty())
      for (std::size_t c = 0; c < reader_->cameras().size(); ++c) cameras_.push_back(c);
    for (std::size_t c : cameras_)
      if (c >= reader_->cameras().size())
        return Error{fmt::format("{}: there is no camera {} (the session has {}: 0..{})", session_.string(), c,
                                 reader_->cameras().size(), reader_->cameras().size() - 1)};
    return {};
  }

  // Each camera with the pad calibration the loaders' geometry is made from.
  Status geometry() {
    auto calibrations = calib::pad_calibrations(*reader_);
    if (!calibrations) return calibrations.error();
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      const CameraInfo& camera = reader_->cameras()[cameras_[k]];
      const auto& cal = calibrations.value()[cameras_[k]];
      if (!cal)
        return Error{
            fmt::format("{}: camera {} has no pad calibration in the session; the layout needs each camera's "
                        "pose: run `pvcap calibrate pad {}` (or leave the camera out with --cameras)",
                        session_.string(), camera.name, session_.string())};
      // pvcap's corners run (0,0), (185,0), (185,105), (0,105); the loaders' (185,0), (185,105), (0,105), (0,0).
      const auto& c = *cal->pad_corners_px;
      std::array<cv::Point2d, 4> measured{c[1], c[2], c[3], c[0]};
      cv::Matx33d K = cal->model.K;
      if (o_.paper_crop) {
        // cv::resize maps a pixel centre x of the box to (x - x0 + 0.5) * s - 0.5: an affine map A,
        // which the intrinsics absorb (fx' = s fx, cx' = (cx - x0 + 0.5) s - 0.5) and the corners follow.
        const cv::Rect box = calib::paper_crop_box(c, {camera.width, camera.height});
        const double sx = 480.0 / box.width, sy = 384.0 / box.height;
        const cv::Matx33d A(sx, 0, (0.5 - box.x) * sx - 0.5, 0, sy, (0.5 - box.y) * sy - 0.5, 0, 0, 1);
        K = A * K;
        for (auto& q : measured) {
          const cv::Vec3d v = A * cv::Vec3d(q.x, q.y, 1);
          q = {v[0], v[1]};
        }
        crops_.push_back(box);
      }
      measured_pv_order_.push_back(measured);
      const PvPose pose = fit_pv_pose(K, measured_pv_order_.back());
      std::vector<double> d = cal->model.distortion;
      d.resize(8, 0.0);  // k1 k2 p1 p2 k3, then the rational model's k4 k5 k6 (unused: 0)
      pv_cameras_[std::to_string(k)] = {{"ModelViewMatrix", matrix(pose.model_view)},
                                        {"fx", K(0, 0)},
                                        {"fy", K(1, 1)},
                                        {"cx", K(0, 2)},
                                        {"cy", K(1, 2)},
                                        {"k1", d[0]},
                                        {"k2", d[1]},
                                        {"p1", d[2]},
                                        {"p2", d[3]},
                                        {"k3", d[4]},
                                        {"k4", d[5]},
                                        {"k5", d[6]},
                                        {"k6", d[7]}};
      result_.cameras.push_back({camera.name, pose.rms_px, pose.max_px});
    }
    return {};
  }

  // The takes of this folder to export, and which samples each keeps: every selected camera's
  // frame stored and a pressure frame paired.
  Status select() {
    auto takes = protocol::read_takes(session_);
    if (!takes) return takes.error();
    takes_ = std::move(takes.value());
    std::vector<const protocol::TakeRow*> chosen;
    std::set<std::string> names;
    for (const auto& t : takes_.takes) {
      if (fs::absolute(t.session).lexically_normal().string() != here_) continue;  // an earlier folder's
      names.insert(t.sequence);
      if (o_.take && t.sequence != *o_.take) continue;
      if (!t.first_sample || !t.end_sample || *t.end_sample <= *t.first_sample) continue;  // nothing recorded
      if (t.status == "done" || o_.include_all) chosen.push_back(&t);
    }
    if (takes_.takes.empty())
      return Error{
          fmt::format("{}: the session ran no protocol, so it has no takes to export as sequences", session_.string())};
    if (o_.take && !names.count(*o_.take)) {
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      return Error{fmt::format("{}: no take named '{}' (takes: {})", session_.string(), *o_.take, list)};
    }
    auto samples = reader_->sample_infos();
    if (!samples) return samples.error();
    samples_ = std::move(samples.value());
    for (const protocol::TakeRow* t : chosen) {
      PlannedSequence p;
      p.take = t;
      for (std::size_t i = *t->first_sample; i < *t->end_sample && i < samples_.size(); ++i) {
        if (wanted(samples_[i]))
          p.samples.push_back(i);
        else
          ++p.left_out;
      }
      if (p.samples.empty()) continue;  // a time range that misses the take
      total_ += p.samples.size();
      plan_.push_back(std::move(p));
    }
    return {};
  }

  bool wanted(const SampleInfo& s) const {
    const double at_s = double(s.t_ns - reader_->info().started_host_ns) / 1e9;
    if ((o_.from_s && at_s < *o_.from_s) || (o_.to_s && at_s >= *o_.to_s)) return false;
    bool complete = s.pressure.has_value();
    for (std::size_t c : cameras_) {
      const auto f = std::find_if(s.cameras.begin(), s.cameras.end(), [&](const SampleCamera& sc) {
        return sc.device_id == reader_->cameras()[c].device_id;
      });
      complete &= f != s.cameras.end() && f->in_video;
    }
    return complete;
  }

  // The participant's folder, and each sequence's: the take's name; a folder already holding
  // another take gets "(2)", "(3)"...
  Status folders() {
    std::error_code ec;
    fs::create_directories(o_.out, ec);
    if (ec) return Error{fmt::format("{}: cannot be made: {}", o_.out.string(), ec.message())};
    const auto& info = reader_->info();
    pseudonym_ = info.participant ? info.participant->pseudonym : "unrecorded";
    if (!safe_name(pseudonym_))
      return Error{
          fmt::format("{}: the participant's pseudonym '{}' cannot be a folder name (letters, digits, - and "
                      "_ only)",
                      (session_ / "session.db").string(), pseudonym_)};
    auto folder = participant_folder(o_.out, pseudonym_);
    if (!folder) return folder.error();
    participant_folder_ = folder.value();
    result_.participant_folder = o_.out / participant_folder_;
    std::set<std::string> taken;
    for (auto& p : plan_) {
      const json source = {{"session", here_}, {"step", p.take->step}, {"start_ns", p.take->start_ns.value_or(0)}};
      if (!safe_name(p.take->sequence))
        return Error{fmt::format("{}: take name '{}' cannot be a folder name", session_.string(), p.take->sequence)};
      const auto named = o_.sequence_folders.find(fmt::format("{}:{}", p.take->step, p.take->start_ns.value_or(0)));
      if (named != o_.sequence_folders.end()) {
        if (auto s = named_folder(p, named->second, source); !s.ok()) return s;
        taken.insert(named->second);
        continue;
      }
      for (int n = 1;; ++n) {
        const std::string name = n == 1 ? p.take->sequence : fmt::format("{}({})", p.take->sequence, n);
        if (taken.count(name)) continue;
        const fs::path dir = result_.participant_folder / name, marker = dir / "pvcap_source.json";
        if (fs::exists(marker)) {
          std::ifstream in(marker);
          const json there = json::parse(in, nullptr, false);
          if (there != source) continue;  // another take's folder (another session, or a retake)
        } else if (fs::exists(dir) && !fs::is_empty(dir)) {
          continue;  // something not ours
        }
        fs::create_directories(dir, ec);
        if (ec) return Error{fmt::format("{}: cannot be made: {}", dir.string(), ec.message())};
        if (!fs::exists(marker))
          if (auto w = write_file_atomically(marker, source.dump(2) + "\n", Durability::Renamed); !w.ok()) return w;
        p.folder = name;
        taken.insert(name);
        break;
      }
    }
    return {};
  }

  // A take's folder given by the caller: made (or found holding this take); one holding another
  // take is an error, never overwritten.
  Status named_folder(PlannedSequence& p, const std::string& name, const json& source) {
    if (!safe_name(name)) return Error{fmt::format("the sequence folder '{}' is not a name pvcap makes", name)};
    const fs::path dir = result_.participant_folder / name, marker = dir / "pvcap_source.json";
    if (fs::exists(marker)) {
      std::ifstream in(marker);
      if (json::parse(in, nullptr, false) != source)
        return Error{fmt::format("{}: holds another take than {} step {}; export into an empty folder", dir.string(),
                                 here_, p.take->step)};
    } else if (fs::exists(dir) && !fs::is_empty(dir)) {
      return Error{fmt::format("{}: holds files pvcap did not write; export into an empty folder", dir.string())};
    }
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return Error{fmt::format("{}: cannot be made: {}", dir.string(), ec.message())};
    if (!fs::exists(marker))
      if (auto w = write_file_atomically(marker, source.dump(2) + "\n", Durability::Renamed); !w.ok()) return w;
    p.folder = name;
    return {};
  }

  std::string meta_name() const { return o_.layout == Layout::PressureVision ? "metadata.json" : "meta.json"; }

  Status write_sequence(const PlannedSequence& p) {
    const fs::path dir = result_.participant_folder / p.folder;
    SequenceResult seq{(fs::path(participant_folder_) / p.folder).string(), p.take->status, p.samples.size(),
                       p.left_out};
    if (fs::exists(dir / meta_name())) {  // finished by an earlier run
      seq.was_complete = true;
      done_ += p.samples.size();
      result_.frames_found += p.samples.size();
      if (o_.progress) o_.progress(done_, total_);
      result_.sequences.push_back(seq);
      return {};
    }
    // A killed run's half-written files (never renamed into place) are of no use.
    std::error_code ec;
    for (const auto& e : fs::recursive_directory_iterator(dir, ec))
      if (e.is_regular_file() && e.path().filename().string().find(".tmp-") != std::string::npos)
        fs::remove(e.path(), ec);
    for (std::size_t k = 0; k < cameras_.size(); ++k) fs::create_directories(dir / fmt::format("camera_{}", k), ec);
    fs::create_directories(dir / "force", ec);
    if (ec) return Error{fmt::format("{}: cannot be made: {}", dir.string(), ec.message())};
    FileSums sums;
    json timesteps = json::array();
    if (Status s = write_frames(p, dir, sums, timesteps); !s.ok()) return s;
    if (result_.interrupted) {
      result_.sequences.push_back(seq);
      return {};
    }
    if (Status s = write_manifest(dir, sums); !s.ok()) return s;
    if (auto w = write_file_atomically(dir / meta_name(), metadata(p, timesteps).dump(1) + "\n", Durability::Renamed);
        !w.ok())
      return w;
    result_.sequences.push_back(seq);
    return {};
  }

  // The sequence's JPEGs by the lanes (export/jpeg_lanes.h) while this thread writes the force files
  // and shows each sample's progress once every lane has passed it.
  Status write_frames(const PlannedSequence& p, const fs::path& dir, FileSums& sums, json& timesteps) {
    if (!jpegs_) {
      auto opened = JpegLanes::open(session_, {cameras_, crops_, o_.paper_crop, o_.jpeg_quality});
      if (!opened) return opened.error();
      jpegs_ = std::move(opened.value());
    }
    jpegs_->start(p.samples, dir, stop_);
    const Status forces = write_forces(p, dir, sums, timesteps);
    const Status jpegs = jpegs_->finish(/*abandon=*/!forces.ok(), sums);
    return forces.ok() ? jpegs : forces;
  }

  // A stop leaves the sequence interrupted (resumed by the next run) unless every sample was done.
  Status write_forces(const PlannedSequence& p, const fs::path& dir, FileSums& sums, json& timesteps) {
    const std::string force_ext = o_.npy ? "npy" : "pkl";
    for (std::size_t t = 0; t < p.samples.size(); ++t) {
      const SampleInfo& s = samples_[p.samples[t]];
      timesteps.push_back(double(s.t_ns - reader_->info().started_host_ns) / 1e9);
      bool wrote = false;
      const fs::path force = dir / "force" / fmt::format("{:05d}.{}", t, force_ext);
      if (!stop_.load() && !fs::exists(force)) {
        auto f = loader_force(*reader_, *s.pressure);
        if (!f) return f.error();
        const std::string bytes = o_.npy ? numpy_npy(f.value()) : numpy_pickle(f.value());
        if (auto w = write_file_atomically(force, bytes, Durability::Renamed); !w.ok()) return w;
        sums[fs::relative(force, dir).string()] = {bytes.size(), sha256_hex(bytes)};
        wrote = true;
      }
      const bool lanes_ok = jpegs_->wait_past(t);
      if (stop_.load()) {
        result_.interrupted = true;
        return {};
      }
      if (!lanes_ok) return {};  // the lane's error is returned by finish()
      wrote = wrote || jpegs_->wrote(t);
      ++(wrote ? result_.frames_written : result_.frames_found);
      if (o_.progress) o_.progress(++done_, total_);
    }
    return {};
  }

  // The manifest (written before the metadata: a sequence is complete once its metadata exists).
  // Files an earlier run wrote are read back for their checksums.
  Status write_manifest(const fs::path& dir, const FileSums& sums) {
    json manifest = {{"algorithm", "sha256"}, {"files", json::object()}};
    std::vector<fs::path> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file() && e.path().filename() != "manifest.json" && e.path().filename() != meta_name() &&
          e.path().string().find(".tmp-") == std::string::npos)
        files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      const std::string name = fs::relative(f, dir).string();
      if (const auto known = sums.find(name); known != sums.end()) {
        manifest["files"][name] = {{"bytes", known->second.first}, {"sha256", known->second.second}};
        continue;
      }
      auto sum = sha256_file(f);
      if (!sum) return sum.error();
      manifest["files"][name] = {{"bytes", fs::file_size(f)}, {"sha256", sum.value()}};
    }
    return write_file_atomically(dir / "manifest.json", manifest.dump(1) + "\n", Durability::Renamed);
  }

  json metadata(const PlannedSequence& p, const json& timesteps) const {
    const auto& info = reader_->info();
    json meta;
    meta["num_cameras"] = cameras_.size();
    meta["num_frames"] = p.samples.size();
    meta["timesteps"] = timesteps;
    meta["participant"] = {
        {"Skintone", info.participant ? info.participant->skin_tone : "unrecorded"},
        {"Light Direction", light_direction_words(info.conditions ? info.conditions->lighting : "")}};
    if (o_.layout == Layout::PressureVision) {
      meta["camera_calibrations"] = pv_cameras_;
    } else {
      meta["camera_ids"] = json::array();
      meta["is_weak"] = false;
      for (std::size_t k = 0; k < cameras_.size(); ++k) {
        meta["camera_ids"].push_back(k);
        json per_frame = json::object();
        const cv::Matx33d h = corner_homography(measured_pv_order_[k]);
        json imgpts = json::array();
        for (const auto& q : measured_pv_order_[k]) imgpts.push_back({q.x, q.y});
        for (std::size_t t = 0; t < p.samples.size(); ++t)
          per_frame[std::to_string(t)] = {{"homography", matrix(h)}, {"imgpts", imgpts}};
        meta["camera_calibrations"][std::to_string(k)] = per_frame;
      }
    }
    json cams = json::array();
    for (std::size_t k = 0; k < cameras_.size(); ++k)
      cams.push_back(
          {{"camera", k},
           {"crop_box", o_.paper_crop ? json{crops_[k].x, crops_[k].y, crops_[k].width, crops_[k].height} : json()},
           {"name", reader_->cameras()[cameras_[k]].name},
           {"serial", reader_->cameras()[cameras_[k]].serial},
           {"loader_corner_rms_px", result_.cameras[k].loader_corner_rms_px},
           {"loader_corner_max_px", result_.cameras[k].loader_corner_max_px}});
    meta["pvcap"] = {{"session", here_},
                     {"participant_code", pseudonym_},
                     {"take",
                      {{"step", p.take->step},
                       {"sequence", p.take->sequence},
                       {"status", p.take->status},
                       {"action", p.take->action},
                       {"hand", p.take->hand},
                       {"force", p.take->force},
                       {"repetitions", p.take->repetitions}}},
                     {"samples", p.samples},
                     {"samples_left_out", p.left_out},
                     {"cameras", cams},
                     {"force_units", "loader counts: kPa = value / 2.7125 (1736 per newton on a 1.25 mm sensel)"},
                     {"paper_crop", o_.paper_crop},
                     {"timesteps", "seconds from the session's start on its one clock (CLOCK_MONOTONIC)"}};
    return meta;
  }

  const fs::path session_;
  const ExportOptions& o_;
  const std::atomic<bool>& stop_;
  const std::string here_;
  std::unique_ptr<SessionReader> reader_;
  std::unique_ptr<JpegLanes> jpegs_;  // opened for the first sequence with frames to write
  std::vector<std::size_t> cameras_;
  json pv_cameras_ = json::object();
  std::vector<std::array<cv::Point2d, 4>> measured_pv_order_;
  std::vector<cv::Rect> crops_;  // with --crop-paper: each camera's box in the recorded frame
  protocol::SessionTakes takes_;
  std::vector<SampleInfo> samples_;
  std::vector<PlannedSequence> plan_;
  std::size_t total_ = 0, done_ = 0;
  std::string pseudonym_, participant_folder_;
  ExportResult result_;
};

}  // namespace

Result<ExportResult> export_session(const fs::path& session, const ExportOptions& o, const std::atomic<bool>& stop) {
  return SessionExport(session, o, stop).run();
}

}  // namespace pvcap::exporting
