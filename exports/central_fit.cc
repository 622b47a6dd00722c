#include "exports/central_fit.h"

#include <cmath>
#include <complex>
#include <limits>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>

#include "exports/central_models.h"
#include "stereo/panorama.h"
#include "stereo/sparse_triangulation.h"

namespace omni::exports {
namespace {

// A grid pixel of a ring and its ray (non-central model) in the rig frame.
struct Sample {
  Eigen::Vector2d pixel;
  Eigen::Vector3d origin, direction;
};

std::vector<Sample> RingSamples(const RigModel& model, Mirror mirror, int step,
                                const Pose<double>& rig_from_cam) {
  std::vector<Sample> samples;
  for (int v = 0; v < model.params().image_height; v += step) {
    for (int u = 0; u < model.params().image_width; u += step) {
      const auto ray = model.Unproject(Eigen::Vector2d(u, v));
      if (!ray || ray->mirror != mirror) continue;
      samples.push_back({Eigen::Vector2d(u, v), rig_from_cam * ray->ray.origin,
                         rig_from_cam.rotation * ray->ray.direction});
    }
  }
  return samples;
}

template <CentralModel K>
struct CentralCost {
  static constexpr int kN = K == CentralModel::kUnified ? kUnifiedParameters : kDoubleSphereParameters;
  CentralCost(const Eigen::Vector2d& pixel, const Eigen::Vector3d& point)
      : pixel(pixel), point(point) {}
  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* q, T* residual) const {
    const T x[3] = {T(point.x()), T(point.y()), T(point.z())};
    T p[3];
    ceres::AngleAxisRotatePoint(rotation, x, p);
    for (int k = 0; k < 3; ++k) p[k] += translation[k];
    T px[2];
    const bool ok = K == CentralModel::kUnified ? ProjectUnified(q, p, px)
                                                : ProjectDoubleSphere(q, p, px);
    if (!ok) return false;
    residual[0] = px[0] - T(pixel.x());
    residual[1] = px[1] - T(pixel.y());
    return true;
  }
  Eigen::Vector2d pixel;
  Eigen::Vector3d point;
};

bool ProjectRing(const CentralRing& ring, const Eigen::Vector3d& point_in_rig,
                 Eigen::Vector2d* pixel) {
  const Eigen::Vector3d p = ring.cam_from_rig * point_in_rig;
  return ring.model == CentralModel::kUnified
             ? ProjectUnified(ring.intrinsics.data(), p.data(), pixel->data())
             : ProjectDoubleSphere(ring.intrinsics.data(), p.data(), pixel->data());
}

// The unified model's start (see the header): the frame from the ring's focus and axis, the
// parity and azimuth offset from the pixels' polar angles, f by least squares at xi = 1.
CentralRing StartUnified(const std::vector<Sample>& samples, const Eigen::Vector3d& focus,
                         const Eigen::Vector3d& axis, const Eigen::Vector2d& principal) {
  constexpr double kStartDistance = 2000;
  // Do the pixels farther out look higher (along +axis)? Then z points against the axis.
  double sum_re = 0, sum_r = 0, sum_e = 0, sum_rr = 0;
  const double n = static_cast<double>(samples.size());
  std::vector<Eigen::Vector3d> w(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) {
    w[i] = (samples[i].origin + kStartDistance * samples[i].direction - focus).normalized();
    const double r = (samples[i].pixel - principal).norm(), e = w[i].dot(axis);
    sum_re += r * e;
    sum_r += r;
    sum_e += e;
    sum_rr += r * r;
  }
  const bool outward_up = sum_re / n - (sum_r / n) * (sum_e / n) > 0;
  const Eigen::Vector3d z = outward_up ? Eigen::Vector3d(-axis) : axis;
  Eigen::Vector3d x0 = Eigen::Vector3d::UnitX() - z * z.x();
  if (x0.norm() < 0.1) x0 = Eigen::Vector3d::UnitY() - z * z.y();
  x0.normalize();
  const Eigen::Vector3d y0 = z.cross(x0);
  std::complex<double> same(0, 0), reversed(0, 0);
  for (size_t i = 0; i < samples.size(); ++i) {
    const double psi = std::atan2(w[i].dot(y0), w[i].dot(x0));
    const Eigen::Vector2d d = samples[i].pixel - principal;
    const double phi = std::atan2(d.y(), d.x());
    same += std::polar(1.0, phi - psi);
    reversed += std::polar(1.0, phi + psi);
  }
  const double s = std::abs(same) >= std::abs(reversed) ? 1.0 : -1.0;
  // Turning x by beta about z makes azimuth psi - beta; we want phi = s (psi - beta).
  const double beta = s > 0 ? -std::arg(same) : std::arg(reversed);
  const Eigen::Vector3d x = std::cos(beta) * x0 + std::sin(beta) * y0;
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r.row(0) = x.transpose();
  r.row(1) = y.transpose();
  r.row(2) = z.transpose();
  CentralRing ring;
  ring.model = CentralModel::kUnified;
  ring.cam_from_rig = {r, -(r * focus)};
  // At xi = 1: pixel radius = f sin(theta) / (cos(theta) + 1).
  double num = 0, den = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double cos_t = z.dot(w[i]), sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
    const double g = sin_t / (cos_t + 1.0);
    num += g * (samples[i].pixel - principal).norm();
    den += g * g;
  }
  const double f = den > 0 ? num / den : 1000;
  ring.intrinsics = {1.0, f, s * f, principal.x(), principal.y(), 0, 0, 0, 0};
  return ring;
}

// Stops the fit once the RMS is below 1e-5 px: on a single-viewpoint rig the central model is
// exact and the cost only creeps towards zero (200 iterations, 10 s, for nothing).
class StopWhenExact : public ceres::IterationCallback {
 public:
  explicit StopWhenExact(int samples) : samples_(samples) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    return 2 * s.cost / samples_ < 1e-10 ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                         : ceres::SOLVER_CONTINUE;
  }

 private:
  double samples_;
};

template <CentralModel K>
void Fit(const std::vector<Sample>& samples, const std::vector<double>& distances,
         CentralRing* ring) {
  Eigen::AngleAxisd aa(ring->cam_from_rig.rotation);
  double rotation[3], translation[3];
  Eigen::Map<Eigen::Vector3d> rotation_vector(rotation), translation_vector(translation);
  rotation_vector = aa.angle() * aa.axis();
  translation_vector = ring->cam_from_rig.translation;
  ceres::Problem problem;
  for (const Sample& s : samples) {
    for (double distance : distances) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<CentralCost<K>, 2, 3, 3, CentralCost<K>::kN>(
              new CentralCost<K>(s.pixel, s.origin + distance * s.direction)),
          nullptr, rotation, translation, ring->intrinsics.data());
    }
  }
  if (K == CentralModel::kDoubleSphere) {  // alpha in [0, 1]
    problem.SetParameterLowerBound(ring->intrinsics.data(), 5, 0.0);
    problem.SetParameterUpperBound(ring->intrinsics.data(), 5, 1.0);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 200;
  so.num_threads = 2;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  StopWhenExact stop(std::max(1, problem.NumResiduals() / 2));
  so.callbacks.push_back(&stop);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  ring->iterations = static_cast<int>(summary.iterations.size()) - 1;
  ring->fit_rms_px = std::sqrt(2 * summary.final_cost / std::max(1, problem.NumResiduals() / 2));
  Eigen::Map<const Eigen::Vector3d> rv(rotation);
  ring->cam_from_rig.rotation =
      rv.norm() > 0 ? Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix()
                    : Eigen::Matrix3d::Identity();
  ring->cam_from_rig.translation = Eigen::Map<const Eigen::Vector3d>(translation);
}

void Evaluate(const std::vector<Sample>& samples, const CentralFitOptions& options, int width,
              int height, CentralRing* ring) {
  ring->residuals.clear();
  ring->residual_map = cv::Mat(height, width, CV_32F, cv::Scalar(std::nanf("")));
  std::vector<double> distances = options.report_distances_mm;
  distances.push_back(options.map_distance_mm);
  for (size_t k = 0; k < distances.size(); ++k) {
    const bool map_only = k + 1 == distances.size();
    CentralResidual r;
    r.distance_mm = distances[k];
    double squared = 0;
    for (const Sample& s : samples) {
      Eigen::Vector2d px;
      ++r.pixels;
      if (!ProjectRing(*ring, s.origin + distances[k] * s.direction, &px)) {
        ++r.not_projected;
        continue;
      }
      const double e = (px - s.pixel).norm();
      squared += e * e;
      r.max_px = std::max(r.max_px, e);
      if (map_only) {
        const cv::Rect block(static_cast<int>(s.pixel.x()), static_cast<int>(s.pixel.y()),
                             options.report_step_px, options.report_step_px);
        ring->residual_map(block & cv::Rect(0, 0, width, height)).setTo(e);
      }
    }
    const int projected = r.pixels - r.not_projected;
    r.rms_px = projected > 0 ? std::sqrt(squared / projected) : 0;
    if (!map_only) ring->residuals.push_back(r);
  }
}

}  // namespace

const char* CentralModelName(CentralModel model) {
  return model == CentralModel::kUnified ? "unified (omni + radtan)" : "double sphere";
}

std::vector<CentralRing> FitCentral(const RigModel& model, CentralModel kind,
                                      const CentralFitOptions& options) {
  // The output frame from C (C itself, or mirror 1's body), as triangulate's.
  const Pose<double> rig_from_cam =
      stereo::FramesOf(model.params(), options.frame, nullptr).out_from_cam;
  const stereo::PanoramaGeometry geometry = stereo::MakePanoramaGeometry(model, {});
  const Eigen::Vector3d axis = rig_from_cam.rotation * geometry.cam_from_cylinder.col(2);
  const Eigen::Vector2d principal(model.params().camera[kCx], model.params().camera[kCy]);
  std::vector<CentralRing> rings(model.params().Paths());
  for (int m = 0; m < static_cast<int>(rings.size()); ++m) {
    const Mirror mirror = m == 0 ? Mirror::kOne : Mirror::kTwo;
    const std::vector<Sample> fit = RingSamples(model, mirror, options.fit_step_px, rig_from_cam);
    CentralRing ring = StartUnified(fit, rig_from_cam * geometry.viewpoint_in_cam[m], axis,
                                    principal);
    Fit<CentralModel::kUnified>(fit, options.fit_distances_mm, &ring);
    if (kind == CentralModel::kDoubleSphere) {
      const double xi = ring.intrinsics[0];
      ring.model = CentralModel::kDoubleSphere;
      ring.intrinsics = {ring.intrinsics[1] / (1 + xi), ring.intrinsics[2] / (1 + xi),
                         ring.intrinsics[3], ring.intrinsics[4], 0.0, xi / (1 + xi)};
      Fit<CentralModel::kDoubleSphere>(fit, options.fit_distances_mm, &ring);
    }
    ring.mirror = mirror;
    Evaluate(RingSamples(model, mirror, options.report_step_px, rig_from_cam), options,
             model.params().image_width, model.params().image_height, &ring);
    rings[m] = std::move(ring);
  }
  return rings;
}

}  // namespace omni::exports
