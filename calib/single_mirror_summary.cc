#include "calib/single_mirror_summary.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "model/conic.h"
#include "model/rig_frames.h"

namespace omni::calib {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The sigma of each output of f (evaluated on the rig) from the covariance over the estimated
// names, by central differences; NaN where f moves with an unobservable parameter.
template <int N>
Eigen::Matrix<double, N, 1> PropagatedSigma(
    const CalibrationResult& result,
    const std::function<Eigen::Matrix<double, N, 1>(const RigParams&)>& f) {
  const RigParams& rig = result.estimate.rig;
  const auto& names = result.estimate.names;
  const int n = static_cast<int>(names.size());
  Eigen::Matrix<double, N, Eigen::Dynamic> jac(N, n);
  for (int i = 0; i < n; ++i) {
    const double h = std::max(1e-6, 1e-4 * result.uncertainty.sigma(i));
    RigParams plus = rig, minus = rig;
    *ParameterOf(&plus, names[i]) += h;
    *ParameterOf(&minus, names[i]) -= h;
    jac.col(i) = (f(plus) - f(minus)) / (2 * h);
  }
  const Eigen::Matrix<double, N, N> cov = jac * result.uncertainty.covariance * jac.transpose();
  Eigen::Matrix<double, N, 1> sigma = cov.diagonal().cwiseMax(0).cwiseSqrt();
  for (const auto& u : result.uncertainty.unobservable) {
    double* value = const_cast<double*>(ParameterOf(rig, u.name));
    if (!value) continue;
    RigParams moved = rig;
    *ParameterOf(&moved, u.name) += 1e-3;
    const Eigen::Matrix<double, N, 1> d = f(moved) - f(rig);
    for (int k = 0; k < N; ++k) {
      if (std::abs(d(k)) > 1e-9) sigma(k) = kNaN;
    }
  }
  return sigma;
}

double SigmaOf(const CalibrationResult& result, const std::string& name) {
  for (size_t i = 0; i < result.estimate.names.size(); ++i) {
    if (result.estimate.names[i] == name) return result.uncertainty.sigma(i);
  }
  for (const auto& u : result.uncertainty.unobservable) {
    if (u.name == name) return kNaN;
  }
  return 0;  // held
}

bool IsOpen(const CalibrationResult& result, const std::string& name) {
  for (const auto& u : result.uncertainty.unobservable) {
    if (u.name == name) return true;
  }
  return false;
}

}  // namespace

SingleMirrorSummary SummariseSingleMirror(const CalibrationResult& result) {
  const RigParams& rig = result.estimate.rig;
  SingleMirrorSummary s;
  s.R = rig.mirror1_shape[kShapeC];
  s.K = rig.mirror1_shape[kShapeK];
  s.sigma_R = SigmaOf(result, "mirror1.R");
  s.sigma_K = SigmaOf(result, "mirror1.K");
  // The kind the data tell: a sphere or paraboloid where K is within 2 sigma of 0 or -1.
  s.mirror = ConicKindName(
      KindOfConic(s.K, std::isfinite(s.sigma_K) && s.sigma_K > 0 ? 2 * s.sigma_K : 1e-9));
  // The mirror's axis in C against the camera's: the tilt's angle.
  const auto axis_tilt = [](const RigParams& r) {
    const Eigen::Vector3d axis = PoseFromBlock(r.mirror1_pose.data()).Rotate(Eigen::Vector3d::UnitZ());
    return Eigen::Matrix<double, 1, 1>(std::acos(std::min(1.0, axis.z())));
  };
  s.axis_tilt_rad = axis_tilt(rig)(0);
  // The angle is not smooth at 0: its sigma from the tilt components' (rx, ry) sigmas.
  const double srx = SigmaOf(result, "mirror1.rx"), sry = SigmaOf(result, "mirror1.ry");
  s.axis_tilt_sigma_rad = std::sqrt(0.5 * (srx * srx + sry * sry));
  double far = 0;
  if (rig.lens == LensKind::kPerspective &&
      Conic<double>{s.R, s.K}.FarFocus(&far)) {
    s.has_offset = true;
    const auto offset = [](const RigParams& r) {
      double f = 0;
      Conic<double>{r.mirror1_shape[kShapeC], r.mirror1_shape[kShapeK]}.FarFocus(&f);
      const Pose<double> cam_from_m1 = PoseFromBlock(r.mirror1_pose.data());
      // The camera's centre (C's origin) in M1, minus the far focus there.
      const Eigen::Vector3d camera_in_m1 = cam_from_m1.Inverse().translation;
      return Eigen::Vector3d(camera_in_m1 - Eigen::Vector3d(0, 0, r.vertex_z + f));
    };
    s.offset_mm = offset(rig);
    s.offset_sigma_mm = PropagatedSigma<3>(result, offset);
  }
  const NonCentralDecision& decision = result.solve.noncentral;
  if (decision.tested && !decision.decided) {
    s.central_kept = true;
    s.fit_failure = decision.failure;
    if (decision.fit) {
      const SingleMirrorSummary fit = SummariseSingleMirror(*decision.fit);
      s.has_fit = true;
      s.fit_axis_tilt_rad = fit.axis_tilt_rad;
      s.fit_axis_tilt_sigma_rad = fit.axis_tilt_sigma_rad;
      s.fit_has_offset = fit.has_offset;
      s.fit_offset_mm = fit.offset_mm;
      s.fit_offset_sigma_mm = fit.offset_sigma_mm;
    }
  }
  // What the photos leave open.
  if (rig.lens == LensKind::kTelecentric) {
    s.open.push_back("the camera's distance along its axis (a telecentric lens has no centre) and "
                     "the mirror's shift across it (the principal point's): held");
  }
  if (SigmaOf(result, "mirror1.R") == 0) {
    s.open.push_back("the mirror's absolute size: R is held at the start's " +
                     std::to_string(s.R).substr(0, 7) +
                     " mm (set by the start's rim diameter: measured, or init's nominal one "
                     "where none was given); distances scale with it");
  } else if (IsOpen(result, "mirror1.R")) {
    s.open.push_back("the mirror's absolute size (R): the photos fix its shape, not its scale; a "
                     "measured length (the rim's diameter, a prior on R) would");
  }
  for (const auto& u : result.uncertainty.unobservable) {
    s.open.push_back(u.name + ": " + u.hint);
  }
  return s;
}

std::string SingleMirrorText(const SingleMirrorSummary& s) {
  auto pm = [](double v, double sigma, const char* unit) {
    char buf[96];
    if (std::isnan(sigma)) {
      std::snprintf(buf, sizeof(buf), "%.4g%s (not determined)", v, unit);
    } else if (sigma == 0) {
      std::snprintf(buf, sizeof(buf), "%.4g%s (held)", v, unit);
    } else {
      std::snprintf(buf, sizeof(buf), "%.4g +- %.2g%s", v, sigma, unit);
    }
    return std::string(buf);
  };
  const char* article = s.mirror[0] == 'e' || s.mirror[0] == 'o' ? "an " : "a ";
  std::string text = "single-mirror camera: " + std::string(article) + s.mirror + ", R " + pm(s.R, s.sigma_R, " mm") +
                     ", K " + pm(s.K, s.sigma_K, "") + "\n";
  text += "  the mirror's axis against the camera's: " +
          pm(s.axis_tilt_rad * 180 / M_PI, s.axis_tilt_sigma_rad * 180 / M_PI, " deg") + "\n";
  if (s.has_offset) {
    text += "  the camera's centre from the mirror's far focus (0: a central camera), in the "
            "mirror's frame: x " + pm(s.offset_mm.x(), s.offset_sigma_mm.x(), " mm") + ", y " +
            pm(s.offset_mm.y(), s.offset_sigma_mm.y(), " mm") + ", z (along the axis) " +
            pm(s.offset_mm.z(), s.offset_sigma_mm.z(), " mm") + "\n";
  }
  if (s.central_kept && s.has_fit) {
    text += "  the non-central fit, not decided by these photos (the central model above "
            "stands): the mirror's axis against the camera's " +
            pm(s.fit_axis_tilt_rad * 180 / M_PI, s.fit_axis_tilt_sigma_rad * 180 / M_PI, " deg");
    if (s.fit_has_offset) {
      text += "; the camera's centre from the mirror's far focus x " +
              pm(s.fit_offset_mm.x(), s.fit_offset_sigma_mm.x(), " mm") + ", y " +
              pm(s.fit_offset_mm.y(), s.fit_offset_sigma_mm.y(), " mm") + ", z " +
              pm(s.fit_offset_mm.z(), s.fit_offset_sigma_mm.z(), " mm");
    }
    text += "\n";
  } else if (s.central_kept) {
    text += "  the non-central fit failed (" + s.fit_failure +
            "): the camera's offset from the mirror's focus is not determined by these photos; "
            "the central model above stands\n";
  }
  for (const std::string& o : s.open) text += "  left open by these photos: " + o + "\n";
  return text;
}

}  // namespace omni::calib
