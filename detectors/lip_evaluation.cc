#include "detectors/lip_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <utility>

#include "detectors/detector_evaluation.h"
#include "detectors/lips/lip_intrinsics.h"
#include "io/text_append.h"
#include "model/lip.h"

namespace omni::detectors {

void LipEvaluation::AddImage(const std::vector<LipEdgeFit>& fits, std::string* point_lines) {
  const RigParams& truth_params = truth_.params();
  for (const LipEdgeFit& fit : fits) {
    EdgeStats& s = stats_[{MirrorIndex(fit.edge.mirror), BandEdgeName(fit.edge.edge),
                           LipCircleName(*fit.edge.circle), LipPathName(*fit.edge.path)}];
    ++s.images;
    std::vector<std::pair<double, double>> azimuth_signed;  // this image's points of the edge
    for (const Eigen::Vector2d& p : fit.edge.points) {
      // Signed: + where the point lies farther from the principal point than the truth.
      Eigen::Vector2d q;
      const double d = DistanceToLipCircleImage(truth_, *fit.edge.path, *fit.edge.circle, p, &q);
      LipBound bound = LipBound::kCircle;
      s.edge_distances.push_back(
          DistanceToLipEdgeImage(truth_, *fit.edge.path, *fit.edge.circle, p, nullptr, &bound));
      if (bound == LipBound::kReflexRim) ++s.on_rim;
      {
        // The fitted ellipse at this point (one Newton step onto the conic from p), against
        // the truth: the edge as the ellipse fit gives it.
        const auto& c = fit.ellipse.conic;
        const double value = c[0] * p.x() * p.x() + c[1] * p.x() * p.y() + c[2] * p.y() * p.y() +
                             c[3] * p.x() + c[4] * p.y() + c[5];
        const Eigen::Vector2d grad(2 * c[0] * p.x() + c[1] * p.y() + c[3],
                                   c[1] * p.x() + 2 * c[2] * p.y() + c[4]);
        const Eigen::Vector2d foot = p - value * grad / grad.squaredNorm();
        const double d_fit = DistanceToLipCircleImage(truth_, *fit.edge.path, *fit.edge.circle, foot);
        if (d_fit < 1e8) s.fit_distances.push_back(d_fit);
      }
      if (d > 1e8) {
        ++s.no_truth;
        continue;
      }
      const Eigen::Vector2d pp(truth_params.camera[kCx], truth_params.camera[kCy]);
      const double signed_d = (p - pp).norm() > (q - pp).norm() ? d : -d;
      s.distances.push_back(d);
      s.signed_sum += signed_d;
      azimuth_signed.push_back({std::atan2(p.y() - pp.y(), p.x() - pp.x()), signed_d});
      if (point_lines) {
        char line[160];
        std::snprintf(line, sizeof line, "point %d %s %.2f %.2f %+.3f\n",
                      MirrorIndex(fit.edge.mirror), LipPathName(*fit.edge.path), p.x(), p.y(),
                      signed_d);
        *point_lines += line;
      }
    }
    constexpr double kCurveDeg = 2.5;
    for (const auto& [azimuth, unused] : azimuth_signed) {
      double sum = 0;
      int count = 0;
      for (const auto& [other, signed_d] : azimuth_signed) {
        if (std::abs(std::remainder(other - azimuth, 2 * M_PI)) <= kCurveDeg * M_PI / 180) {
          sum += signed_d;
          ++count;
        }
      }
      s.curve_offsets.push_back(std::abs(sum / count));
    }
    s.band.push_back(fit.band);
    s.contrast.push_back(fit.contrast);
    s.noise.push_back(fit.noise);
    edges_.push_back(fit.edge);
  }
}

std::string LipEvaluation::Table() const {
  std::string out;
  char line[1024];
  std::snprintf(line, sizeof line,
                "%-6s %-6s %-8s %-12s %6s %7s %8s %8s %8s %8s %7s %8s %6s %8s %8s %8s %6s %8s %9s %7s %8s\n",
                "mirror", "edge", "circle", "path", "images", "points", "mean_px", "p95_px",
                "max_px", "outward", "band", "contrast", "noise", "no_truth", "edge_mn", "edge_p95",
                "on_rim", "curve_mn", "curve_p95", "fit_mn", "fit_p95");
  out += line;
  const auto mean = [](const std::vector<double>& v) {
    double m = 0;
    for (double d : v) m += d / v.size();
    return m;
  };
  for (const auto& [key, s] : stats_) {
    std::snprintf(
        line, sizeof line,
        "%-6d %-6s %-8s %-12s %6d %7zu %8.4f %8.4f %8.4f %+8.4f %7.1f %8.1f %6.2f %8d %8.4f %8.4f "
        "%6d %8.4f %9.4f %7.4f %8.4f\n",
        std::get<0>(key), std::get<1>(key).c_str(), std::get<2>(key).c_str(),
        std::get<3>(key).c_str(), s.images, s.distances.size(), mean(s.distances),
        Percentile(s.distances, 0.95), Percentile(s.distances, 1.0),
        s.signed_sum / std::max<size_t>(1, s.distances.size()), Percentile(s.band, 0.5),
        Percentile(s.contrast, 0.5), Percentile(s.noise, 0.5), s.no_truth, mean(s.edge_distances),
        Percentile(s.edge_distances, 0.95), s.on_rim, mean(s.curve_offsets),
        Percentile(s.curve_offsets, 0.95), mean(s.fit_distances),
        Percentile(s.fit_distances, 0.95));
    out += line;
  }
  return out;
}

void LipEvaluation::DetectAndAdd(const cv::Mat& linear, const RigModel& prior,
                                 const LipDetectorOptions& options, std::string* point_lines) {
  const std::clock_t c0 = std::clock();
  const std::vector<LipEdgeFit> fits = DetectLipEdges(linear, prior, options);
  cpu_ms_.push_back(1000.0 * (std::clock() - c0) / CLOCKS_PER_SEC);
  AddImage(fits, point_lines);
}

std::string LipEvaluation::Report(const RigModel& nominal) const {
  const RigParams& truth = truth_.params();
  std::string out = Table();
  if (!cpu_ms_.empty()) {
    double sum = 0;
    for (double t : cpu_ms_) sum += t;
    io::AppendFormat(&out, "DetectLipEdges CPU per %dx%d image: mean %.1f ms, max %.1f ms\n",
                     truth.image_width, truth.image_height, sum / cpu_ms_.size(),
                     Percentile(cpu_ms_, 1.0));
  }
  out += LipOnlyFitLine("nominal", edges_, nominal, truth);
  out += LipOnlyFitLine("true rig", edges_, truth_, truth);
  return out;
}

std::string LipOnlyFitLine(const char* name, const std::vector<LipEdgeObservation>& edges,
                           const RigModel& prior, const RigParams& truth) {
  char line[512];
  const auto est = InitialIntrinsicsFromLips(edges, prior);
  if (!est) {
    std::snprintf(line, sizeof line, "lip-only fit from the %s model: failed (%zu edges)\n", name,
                  edges.size());
    return line;
  }
  const double f_true = 0.5 * (truth.camera[kFx] + truth.camera[kFy]);
  std::snprintf(line, sizeof line,
                "lip-only fit from the %s model: f %.3f (%+.3f%%), pp - true (%+.3f, %+.3f) px, "
                "rms %.3f px, %d points\n", name, est->f, 100 * (est->f / f_true - 1),
                est->cx - truth.camera[kCx], est->cy - truth.camera[kCy], est->rms_px, est->n_points);
  return line;
}

}  // namespace omni::detectors
