// The `omnistereo` Python module: the calibrated non-central model for Python users,
// vectorised over numpy arrays (the loops run in C++, in parallel, without the GIL), plus the
// detectors and the files a calibration reads and writes. The maths is the library's: RigModel
// (projection, back-projection), Triangulator (midpoint / refined point with covariance),
// detectors::DetectSession, the io readers. Built by python/CMakeLists.txt; `import omnistereo`
// from the build's python/ folder or after `cmake --install`.
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "detectors/detect_image.h"
#include "detectors/detect_session.h"
#include "io/detections_file.h"
#include "io/model_file.h"
#include "io/session_file.h"
#include "model/rig_frames.h"
#include "model/rig_model.h"
#include "model/triangulation.h"
#include "stereo/sparse_triangulation.h"

namespace py = pybind11;

namespace omni::python {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Rows of an (N, k) array; throws ValueError naming the argument otherwise.
ssize_t RowsOf(const Array& a, ssize_t k, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != k) {
    throw py::value_error(std::string(name) + ": expected an array of shape (N, " +
                          std::to_string(k) + ")");
  }
  return a.shape(0);
}

Mirror MirrorOf(int mirror) {
  if (mirror != 1 && mirror != 2) throw py::value_error("mirror: expected 1 or 2");
  return mirror == 1 ? Mirror::kOne : Mirror::kTwo;
}

ReferenceBody FrameOf(const std::string& frame) {
  if (frame == "cam") return ReferenceBody::kCam;
  if (frame == "mirror1") return ReferenceBody::kMirror1;
  throw py::value_error("frame: expected 'cam' or 'mirror1', got '" + frame + "'");
}

// Runs body(i) for i in [0, n) on OpenCV's threads, without the GIL.
template <typename Body>
void ParallelRows(ssize_t n, const Body& body) {
  py::gil_scoped_release release;
  cv::parallel_for_(cv::Range(0, static_cast<int>(n)), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) body(i);
  }, std::max(1.0, n / 4096.0));
}

py::dict CalibrationDict(const CalibrationInfo& c) {
  py::dict d;
  const ssize_t m = static_cast<ssize_t>(c.parameters.size());
  d["parameters"] = c.parameters;
  d["values"] = Array(m, c.values.data());
  d["sigma"] = Array(m, c.sigma.data());
  Array cov({m, m});
  if (static_cast<ssize_t>(c.covariance.size()) == m * m) {
    std::copy(c.covariance.begin(), c.covariance.end(), cov.mutable_data());
  }
  d["covariance"] = cov;
  d["rms_px"] = c.rms_px;
  d["per_mirror_rms_px"] = c.per_mirror_rms_px;
  d["n_observations"] = c.n_observations;
  d["n_rejected"] = c.n_rejected;
  d["n_lip_points"] = c.n_lip_points;
  d["lip_rms_px"] = c.lip_rms_px;
  d["unobservable"] = c.unobservable;
  d["unobservable_hints"] = c.unobservable_hints;
  d["session"] = c.session;
  d["images"] = c.images;
  d["targets"] = c.targets;
  d["tool_version"] = c.tool_version;
  d["date"] = c.date;
  return d;
}

py::dict ObservationsDict(const Observations& obs) {
  py::list images;
  for (const ImageObservations& im : obs.images) {
    py::dict d;
    d["file"] = im.file;
    d["width"] = im.width;
    d["height"] = im.height;
    Array corners({static_cast<ssize_t>(im.corners.size()), ssize_t{5}});
    auto c = corners.mutable_unchecked<2>();
    for (size_t k = 0; k < im.corners.size(); ++k) {
      const CornerObservation& o = im.corners[k];
      c(k, 0) = o.target;
      c(k, 1) = o.id;
      c(k, 2) = o.mirror == Mirror::kOne ? 1 : 2;
      c(k, 3) = o.pixel.x();
      c(k, 4) = o.pixel.y();
    }
    d["corners"] = corners;
    py::list lips;
    for (const LipEdgeObservation& e : im.lips) {
      py::dict l;
      l["mirror"] = e.mirror == Mirror::kOne ? 1 : 2;
      l["edge"] = BandEdgeName(e.edge);
      l["circle"] = e.circle ? py::cast(std::string(LipCircleName(*e.circle))) : py::none();
      l["path"] = e.path ? py::cast(std::string(LipPathName(*e.path))) : py::none();
      Array points({static_cast<ssize_t>(e.points.size()), ssize_t{2}});
      auto p = points.mutable_unchecked<2>();
      for (size_t k = 0; k < e.points.size(); ++k) {
        p(k, 0) = e.points[k].x();
        p(k, 1) = e.points[k].y();
      }
      l["points"] = points;
      lips.append(l);
    }
    d["lips"] = lips;
    images.append(d);
  }
  py::dict out;
  out["session"] = obs.session;
  out["images"] = images;
  return out;
}

// A model file, its RigModel and (built on first use) its Triangulator.
class Model {
 public:
  explicit Model(const std::string& path)
      : path_(path), params_(io::ReadModelFile(path)), model_(params_) {}

  Array Project(const Array& points, int mirror) const {
    const ssize_t n = RowsOf(points, 3, "points");
    const Mirror m = MirrorOf(mirror);
    Array out({n, ssize_t{2}});
    const double* p = points.data();
    double* o = out.mutable_data();
    ParallelRows(n, [&](ssize_t i) {
      const auto px = model_.Project(Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]), m);
      o[2 * i] = px ? px->x() : kNan;
      o[2 * i + 1] = px ? px->y() : kNan;
    });
    return out;
  }

  py::tuple Unproject(const Array& pixels, const std::string& frame) const {
    const ssize_t n = RowsOf(pixels, 2, "pixels");
    const Pose<double> out_from_cam = OutFromCam(FrameOf(frame));
    py::array_t<int8_t> mirror(n);
    Array origin({n, ssize_t{3}}), direction({n, ssize_t{3}});
    const double* p = pixels.data();
    int8_t* mi = mirror.mutable_data();
    double* o = origin.mutable_data();
    double* d = direction.mutable_data();
    ParallelRows(n, [&](ssize_t i) {
      const auto ray = model_.Unproject(Eigen::Vector2d(p[2 * i], p[2 * i + 1]));
      mi[i] = ray ? (ray->mirror == Mirror::kOne ? 1 : 2) : 0;
      const Eigen::Vector3d oi =
          ray ? Eigen::Vector3d(out_from_cam * ray->ray.origin) : Eigen::Vector3d::Constant(kNan);
      const Eigen::Vector3d di = ray ? Eigen::Vector3d(out_from_cam.rotation * ray->ray.direction)
                                     : Eigen::Vector3d::Constant(kNan);
      for (int k = 0; k < 3; ++k) {
        o[3 * i + k] = oi[k];
        d[3 * i + k] = di[k];
      }
    });
    return py::make_tuple(mirror, origin, direction);
  }

  py::dict Triangulate(const Array& pixels1, const Array& pixels2, const std::string& method,
                       double sigma_px, double sigma_px_ring2, bool model_covariance,
                       const std::string& frame) {
    if (params().Single()) {
      throw py::value_error(path_ + ": a single-mirror rig (rig: single) has one view per photo: "
                            "nothing to triangulate from one pixel pair");
    }
    const ssize_t n = RowsOf(pixels1, 2, "pixels1");
    if (RowsOf(pixels2, 2, "pixels2") != n) {
      throw py::value_error("pixels1, pixels2: expected the same number of rows");
    }
    TriangulationOptions options;
    if (method == "reprojection") {
      options.method = TriangulationMethod::kReprojection;
    } else if (method != "midpoint") {
      throw py::value_error("method: expected 'midpoint' or 'reprojection', got '" + method + "'");
    }
    if (!(sigma_px >= 0) || !(sigma_px_ring2 >= 0)) {
      throw py::value_error("sigma_px, sigma_px_ring2: expected numbers >= 0");
    }
    options.sigma_px = sigma_px;
    options.sigma_px_ring2 = sigma_px_ring2;
    options.model_covariance = model_covariance;
    options.reference = FrameOf(frame);
    const Pose<double> out_from_cam = OutFromCam(options.reference);
    if (!triangulator_) triangulator_.emplace(model_);
    const Triangulator& triangulator = *triangulator_;
    Array points({n, ssize_t{3}}), covariance({n, ssize_t{3}, ssize_t{3}}), gap(n);
    const double* a = pixels1.data();
    const double* b = pixels2.data();
    double* pt = points.mutable_data();
    double* cv = covariance.mutable_data();
    double* g = gap.mutable_data();
    ParallelRows(n, [&](ssize_t i) {
      const auto t = triangulator.Triangulate(Eigen::Vector2d(a[2 * i], a[2 * i + 1]),
                                              Eigen::Vector2d(b[2 * i], b[2 * i + 1]), options);
      if (!t) {
        for (int k = 0; k < 3; ++k) pt[3 * i + k] = kNan;
        for (int k = 0; k < 9; ++k) cv[9 * i + k] = kNan;
        g[i] = kNan;
        return;
      }
      const TriangulatedPoint p = stereo::Moved(*t, out_from_cam);
      for (int r = 0; r < 3; ++r) {
        pt[3 * i + r] = p.point_in_cam[r];
        for (int c = 0; c < 3; ++c) cv[9 * i + 3 * r + c] = p.covariance(r, c);
      }
      g[i] = p.gap_mm;
    });
    py::dict out;
    out["points"] = points;
    out["covariance"] = covariance;
    out["gap_mm"] = gap;
    return out;
  }

  const std::string& path() const { return path_; }
  const RigParams& params() const { return params_; }

 private:
  Pose<double> OutFromCam(ReferenceBody frame) const {
    return stereo::FramesOf(params_, frame, nullptr).out_from_cam;
  }

  std::string path_;
  RigParams params_;
  RigModel model_;
  std::optional<Triangulator> triangulator_;
};

// The detectors of a session: its model, targets and lips set up once (the ring views' maps are
// the costly part), then any of its images or others of the same camera.
class Detector {
 public:
  explicit Detector(const std::string& session_path)
      : session_(io::ReadSessionFile(session_path)),
        ctx_(io::ReadModelFile(session_.model_path), session_.targets, session_.use_lips) {}

  // What the lip guide did (detectors/lip_guide.h), after the first detect; empty before.
  const std::string& Guide() const { return guide_; }

  py::dict Detect(const std::optional<std::vector<std::string>>& images) {
    io::Session session = session_;
    if (images) session.images = *images;
    Observations obs;
    {
      py::gil_scoped_release release;
      // The lip guide, as `detect` runs it, once: on the first images detected.
      if (guide_.empty()) {
        guide_ = detectors::GuideLine(detectors::GuideSessionByLips(session, &ctx_));
      }
      obs = detectors::DetectSession(session, &ctx_);
    }
    obs.session = session_.path;
    return ObservationsDict(obs);
  }

 private:
  io::Session session_;
  detectors::DetectorContext ctx_;
  std::string guide_;
};

}  // namespace
}  // namespace omni::python

PYBIND11_MODULE(omnistereo, m) {
  using namespace omni;
  using namespace omni::python;
  m.doc() =
      "The omnistereo toolkit's calibrated non-central catadioptric model, detectors and files.\n"
      "Units: mm, radians, pixels (OpenCV convention: pixel centres at integer coordinates).\n"
      "Mirror 1 is the outer ring, mirror 2 the inner ring. Arrays are numpy float64; invalid\n"
      "results are NaN. Errors in files raise ValueError naming the file and key.";
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);

  py::class_<Model>(m, "Model", "A rig model file (omnistereo-model/1), ideal or calibrated.")
      .def(py::init<const std::string&>(), py::arg("path"),
           "Reads the model file; raises InputError (a ValueError) naming the file and key.")
      .def_property_readonly("path", &Model::path)
      .def_property_readonly("width", [](const Model& s) { return s.params().image_width; })
      .def_property_readonly("height", [](const Model& s) { return s.params().image_height; })
      .def_property_readonly(
          "kind", [](const Model& s) {
            return s.params().kind == ModelKind::kIdeal ? "ideal" : "noncentral";
          })
      .def_property_readonly(
          "rig", [](const Model& s) { return RigKindName(s.params().rig); },
          "'folded' (two mirrors and the reflex: rings 1 and 2) or 'single' (one mirror seen "
          "directly: ring 1 only; mirror 2 projects NaN)")
      .def_property_readonly(
          "lens",
          [](const Model& s) { return LensKindName(s.params().lens); })
      .def_property_readonly(
          "calibration",
          [](const Model& s) -> py::object {
            if (!s.params().calibration) return py::none();
            return CalibrationDict(*s.params().calibration);
          },
          "The calibration: section as a dict (parameters, values, sigma, covariance, rms_px, "
          "...; internal units: px, rad, mm), or None for an uncalibrated model.")
      .def("project", &Model::Project, py::arg("points"), py::arg("mirror"),
           "Pixels (N, 2) of points (N, 3) in the camera frame C (mm) via mirror 1 or 2; NaN "
           "where the mirror does not see the point.")
      .def("unproject", &Model::Unproject, py::arg("pixels"), py::arg("frame") = "cam",
           "Back-projects pixels (N, 2): returns (mirror (N,) int8: 1, 2, or 0 where the pixel "
           "sees neither ring; origin (N, 3) mm on the mirror; unit direction (N, 3)), in C or "
           "in mirror 1's body (frame='mirror1').")
      .def("triangulate", &Model::Triangulate, py::arg("pixels1"), py::arg("pixels2"),
           py::arg("method") = "midpoint", py::arg("sigma_px") = 1.0,
           py::arg("sigma_px_ring2") = 0.0, py::arg("model_covariance") = false,
           py::arg("frame") = "cam",
           "Triangulates pixel pairs (pixels1 via mirror 1, pixels2 via mirror 2, both (N, 2)) "
           "as `omnistereo triangulate` does: returns a dict with points (N, 3) mm, covariance "
           "(N, 3, 3) mm^2 (pixel noise sigma_px, ring 2's sigma_px_ring2 if > 0, plus the "
           "calibration's covariance if model_covariance) and gap_mm (N,), the rays' distance; "
           "NaN rows where a pair cannot be triangulated.");

  py::class_<Detector>(m, "Detector",
                       "The detectors (chessboards, AprilTag grids, lips) of a session file.")
      .def(py::init<const std::string&>(), py::arg("session"),
           "Reads the session (omnistereo-session/1) and its starting model.")
      .def("detect", &Detector::Detect, py::arg("images") = py::none(),
           "Detects the session's images (or the given image paths): the same dict as "
           "read_detections. Unreadable images are skipped (none readable at all raises "
           "InputError); an image of the wrong size raises InputError. The first call corrects the model detection is guided by from the "
           "lips, as `omnistereo detect` does (see guide).")
      .def_property_readonly("guide", &Detector::Guide,
                             "What the lip guide did on the first detect, with a judgement of its fit's rms "
                             "(empty before it).");

  m.def("read_detections",
        [](const std::string& path) { return ObservationsDict(io::ReadDetectionsFile(path)); },
        py::arg("path"),
        "Reads a detections file (omnistereo-detections/1): a dict with session and images, "
        "each image a dict with file, width, height, corners (K, 5) [target, id, mirror, u, v] "
        "and lips (list of dicts: mirror, edge, circle, path, points (P, 2)).");
}
