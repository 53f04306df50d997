// `pvcap._pvcap`: the C++ reader as Python sees it (python/pvcap/__init__.py builds the public API
// on it). Only conversions live here: what is read, and how, is python/session_access.h. Errors of
// the store (a missing, damaged or foreign session; a sample or camera that is not there) raise
// pvcap.StoreError with the reader's message; a malformed argument raises ValueError.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <optional>

#include "core/allocator.h"
#include "python/dataset_access.h"
#include "python/session_access.h"

namespace py = pybind11;
using namespace pvcap;
using pvcap::python::Crop;
using pvcap::python::SessionAccess;

namespace {

struct StoreError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

template <class T>
T value_or_raise(Result<T> r) {
  if (!r) throw StoreError(r.error().message);
  return std::move(r.value());
}

// Reads without the GIL (decoding, warping: other Python threads run meanwhile); a failure raises
// once it is held again.
template <class F>
auto without_gil(F&& read) {
  std::optional<decltype(read())> result;
  {
    py::gil_scoped_release unlocked;
    result.emplace(read());
  }
  return value_or_raise(std::move(*result));
}

Crop crop_of(const py::object& o) {
  if (o.is_none()) return {};
  if (py::isinstance<py::str>(o)) {
    if (o.cast<std::string>() == "paper") return {Crop::Kind::Paper, {}};
    throw py::value_error("crop must be None, \"paper\" or (x, y, width, height); got \"" + o.cast<std::string>() +
                          "\"");
  }
  const auto box = o.cast<std::vector<int>>();
  if (box.size() != 4) throw py::value_error("crop must be (x, y, width, height)");
  return {Crop::Kind::Box, cv::Rect(box[0], box[1], box[2], box[3])};
}

std::optional<cv::Size> size_of(const py::object& o) {
  if (o.is_none()) return std::nullopt;
  const auto wh = o.cast<std::vector<int>>();
  if (wh.size() != 2 || wh[0] <= 0 || wh[1] <= 0) throw py::value_error("size must be (width, height), both above 0");
  return cv::Size(wh[0], wh[1]);
}

// A copy the array owns (the Mat's buffer is not kept alive by Python).
py::object to_array(const cv::Mat& m) {
  if (m.empty()) return py::none();
  if (m.type() == CV_8UC3) {
    py::array_t<std::uint8_t> a({m.rows, m.cols, 3});
    for (int r = 0; r < m.rows; ++r) std::memcpy(a.mutable_data(r, 0, 0), m.ptr(r), std::size_t(m.cols) * 3);
    return a;  // moved implicitly (C++20)
  }
  py::array_t<float> a({m.rows, m.cols});
  for (int r = 0; r < m.rows; ++r) std::memcpy(a.mutable_data(r, 0), m.ptr<float>(r), std::size_t(m.cols) * 4);
  return a;
}

template <class T>
py::array_t<T> column(const std::vector<T>& v) {
  py::array_t<T> a(py::ssize_t(v.size()));
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(T));
  return a;
}

py::array_t<double> matrix(const double* values, int rows, int cols) {
  py::array_t<double> a({rows, cols});
  std::memcpy(a.mutable_data(), values, std::size_t(rows * cols) * sizeof(double));
  return a;
}

py::dict info_of(SessionAccess& s) {
  const SessionInfo& i = s.reader().info();
  py::dict d;
  d["path"] = s.dir().string();
  d["rig"] = i.rig_name;
  d["started_wall_ns"] = i.started_wall_ns;
  d["started_host_ns"] = i.started_host_ns;
  d["ended_cleanly"] = i.ended_host_ns.has_value();
  d["end_reason"] = i.end_reason;
  d["pvcap_version"] = i.pvcap_version;
  d["simulated"] = i.simulated;
  d["participant"] = i.participant ? py::object(py::dict(py::arg("code") = i.participant->pseudonym,
                                                         py::arg("skin_tone") = i.participant->skin_tone,
                                                         py::arg("hand_order") = i.participant->hand_order))
                                   : py::object(py::none());
  d["conditions"] = i.conditions ? py::object(py::dict(py::arg("lighting") = i.conditions->lighting,
                                                       py::arg("sensor_overlay") = i.conditions->sensor_overlay))
                                 : py::object(py::none());
  return d;
}

py::list cameras_of(SessionAccess& s) {
  py::list out;
  for (std::size_t k = 0; k < s.reader().cameras().size(); ++k) {
    const CameraInfo& c = s.reader().cameras()[k];
    py::dict d;
    d["name"] = c.name;
    d["serial"] = c.serial;
    d["width"] = c.width;
    d["height"] = c.height;
    const auto& cal = s.calibration(k);
    if (cal && cal->pad_corners_px) {
      std::vector<double> corners;
      for (const auto& p : *cal->pad_corners_px) corners.insert(corners.end(), {p.x, p.y});
      py::dict c2;
      c2["K"] = matrix(cal->model.K.val, 3, 3);
      c2["distortion"] = cal->model.distortion;
      c2["pad_corners_px"] = matrix(corners.data(), 4, 2);
      d["calibration"] = c2;
    } else {
      d["calibration"] = py::none();
    }
    out.append(d);
  }
  return out;
}

py::dict samples_of(SessionAccess& s) {
  const auto& c = s.samples();
  py::dict d;
  d["index"] = column(c.index);
  d["tick"] = column(c.tick);
  d["t_ns"] = column(c.t_ns);
  d["pressure_sequence"] = column(c.pressure_sequence);
  py::array_t<bool> present({py::ssize_t(c.index.size()), py::ssize_t(c.cameras)});
  for (std::size_t i = 0; i < c.present.size(); ++i) present.mutable_data()[i] = c.present[i] != 0;
  d["cameras_present"] = present;
  return d;
}

py::list takes_of(SessionAccess& s) {
  py::list out;
  for (const auto& t : s.takes()) {
    py::dict d;
    d["step"] = t.step;
    d["sequence"] = t.sequence;
    d["action"] = t.action;
    d["hand"] = t.hand;
    d["force_level"] = t.force;
    d["status"] = t.status;
    d["repetitions"] = t.repetitions;
    d["first_sample"] = t.first_sample ? py::object(py::int_(*t.first_sample)) : py::object(py::none());
    d["end_sample"] = t.end_sample ? py::object(py::int_(*t.end_sample)) : py::object(py::none());
    d["check_ok"] = t.check_ok ? py::object(py::bool_(*t.check_ok)) : py::object(py::none());
    d["check_problems"] = t.check_problems;
    d["mean_newtons"] = t.mean_newtons;
    d["peak_newtons"] = t.peak_newtons;
    out.append(d);
  }
  return out;
}

py::dict dataset_of(const std::string& dir) {
  auto view = value_or_raise(python::open_dataset(dir));
  py::dict d;
  d["name"] = view.name;
  d["withdrawn"] = view.withdrawn;
  d["has_splits"] = view.has_splits;
  py::list sessions;
  for (const auto& s : view.sessions) {
    py::dict e;
    e["folder"] = s.folder;
    e["participant"] = s.participant;
    e["skin_tone"] = s.skin_tone;
    e["hand_order"] = s.hand_order;
    e["lighting"] = s.lighting;
    e["protocol"] = s.protocol;
    e["verify_exit"] = s.verify_exit;
    e["facts_json"] = s.facts_json;
    e["split"] = s.split.empty() ? py::object(py::none()) : py::object(py::str(s.split));
    sessions.append(e);
  }
  d["sessions"] = sessions;
  return d;
}

}  // namespace

PYBIND11_MODULE(_pvcap, m) {
  m.doc() = "pvcap's session store, read through its C++ reader (see the pvcap package)";
  py::register_exception<StoreError>(m, "StoreError", PyExc_RuntimeError);
  // A reader of recorded images, frame after frame: their buffers stay in the heap (core/allocator.h).
  keep_image_buffers_in_heap();

  py::class_<SessionAccess>(m, "SessionHandle")
      .def(py::init([](const std::string& path) { return value_or_raise(SessionAccess::open(path)); }), py::arg("path"))
      .def("info", &info_of)
      .def("cameras", &cameras_of)
      .def("samples", &samples_of)
      .def("takes", &takes_of)
      .def(
          "image",
          [](SessionAccess& s, std::size_t sample, std::size_t camera, const py::object& crop, const py::object& size) {
            const Crop c = crop_of(crop);
            const auto wh = size_of(size);
            return to_array(without_gil([&] { return s.image_rgb(sample, camera, c, wh); }));
          },
          py::arg("sample"), py::arg("camera"), py::arg("crop") = py::none(), py::arg("size") = py::none())
      .def(
          "pressure",
          [](SessionAccess& s, std::size_t sample) {
            return to_array(without_gil([&] { return s.pressure_kpa(sample); }));
          },
          py::arg("sample"))
      .def(
          "pressure_and_force_in_camera",
          [](SessionAccess& s, std::size_t sample, std::size_t camera, const py::object& crop, const py::object& size) {
            const Crop c = crop_of(crop);
            const auto wh = size_of(size);
            double force = 0;
            const cv::Mat m = without_gil([&] { return s.pressure_in_camera(sample, camera, c, wh, &force); });
            return py::make_tuple(to_array(m), force);
          },
          py::arg("sample"), py::arg("camera"), py::arg("crop") = py::none(), py::arg("size") = py::none())
      .def(
          "force", [](SessionAccess& s, std::size_t sample) { return value_or_raise(s.force_n(sample)); },
          py::arg("sample"))
      .def(
          "crop_box",
          [](SessionAccess& s, std::size_t camera, const py::object& crop) {
            const cv::Rect r = value_or_raise(s.crop_box(camera, crop_of(crop)));
            return py::make_tuple(r.x, r.y, r.width, r.height);
          },
          py::arg("camera"), py::arg("crop") = py::none());

  m.def("open_dataset", &dataset_of, py::arg("path"));
}
