#include "report/figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/projection_uncertainty.h"
#include "report/gnuplot.h"

namespace omni::report {
namespace {

// The first readable frame, darkened and grey (colour drawings stand out on it), or a dark
// canvas of the model's size.
cv::Mat Canvas(const ReportInput& in) {
  const RigParams& rig = in.result->rig;
  for (const std::string& path : in.image_paths) {
    cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (image.empty() || image.cols != rig.image_width || image.rows != rig.image_height) continue;
    cv::Mat dark;
    image.convertTo(dark, CV_8U, 0.45);
    cv::Mat bgr;
    cv::cvtColor(dark, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }
  return cv::Mat(rig.image_height, rig.image_width, CV_8UC3, cv::Scalar(24, 24, 24));
}

// Green (small) to red (large) by t in [0, 1].
cv::Scalar Ramp(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return cv::Scalar(40, 255 * (1 - t), 255 * t);
}

bool Write(const std::string& dir, const std::string& name, const cv::Mat& image,
           std::string* note) {
  if (!cv::imwrite(dir + "/" + name, image)) {
    *note = "could not write " + dir + "/" + name;
    return false;
  }
  return true;
}

std::string Plot(const std::string& dir, const std::string& name, const std::string& body,
                 std::string* note) {
  const std::string script = "set terminal pngcairo size 900,420 font 'sans,10'\nset output '" +
                             dir + "/" + name + "'\n" + body;
  return RunGnuplot(script, note) ? name : std::string();
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

}  // namespace

std::string ResidualVectors(const std::string& dir, const ReportInput& in, std::string* note) {
  cv::Mat canvas = Canvas(in);
  std::vector<double> sizes;
  for (const auto& r : in.result->residuals) sizes.push_back(r.residual.norm());
  const double p95 = std::max(Percentile(sizes, 0.95), 1e-6);
  const double scale = 15.0 / p95;  // the 95th percentile drawn 15 px long
  for (const auto& r : in.result->residuals) {
    const cv::Point2d from(r.pixel.x(), r.pixel.y());
    const cv::Point2d to = from + scale * cv::Point2d(r.residual.x(), r.residual.y());
    cv::arrowedLine(canvas, from, to, Ramp(r.residual.norm() / (2 * p95)), 1, cv::LINE_AA, 0, 0.3);
  }
  char legend[160];
  std::snprintf(legend, sizeof(legend), "residuals x%.0f (95th percentile %.3f px = 15 px long)",
                scale, p95);
  cv::putText(canvas, legend, {12, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {255, 255, 255}, 1,
              cv::LINE_AA);
  return Write(dir, "residual_vectors.png", canvas, note) ? "residual_vectors.png" : "";
}

std::string CoverageImage(const std::string& dir, const ReportInput& in, std::string* note) {
  cv::Mat canvas = Canvas(in);
  for (const auto& r : in.result->residuals) {
    cv::circle(canvas, {static_cast<int>(std::lround(r.pixel.x())),
                        static_cast<int>(std::lround(r.pixel.y()))},
               1, r.mirror == 1 ? cv::Scalar(80, 220, 80) : cv::Scalar(255, 120, 255), -1);
  }
  for (const auto& r : in.result->rejected) {
    cv::drawMarker(canvas, {static_cast<int>(std::lround(r.pixel.x())),
                            static_cast<int>(std::lround(r.pixel.y()))},
                   {0, 0, 255}, cv::MARKER_TILTED_CROSS, 9, 2);
  }
  cv::putText(canvas, "corners used: ring 1 green, ring 2 magenta; left out: red crosses",
              {12, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {255, 255, 255}, 1, cv::LINE_AA);
  return Write(dir, "coverage.png", canvas, note) ? "coverage.png" : "";
}

std::string ResidualHistograms(const std::string& dir, const ReportInput& in, std::string* note) {
  std::vector<std::vector<double>> rows[2];
  double sum2[2] = {0, 0};
  for (const auto& r : in.result->residuals) {
    const int m = r.mirror - 1;
    rows[m].push_back({r.residual.x()});
    rows[m].push_back({r.residual.y()});
    sum2[m] += r.residual.squaredNorm();
  }
  std::string body = "set multiplot layout 1,2\nset style fill solid 0.6\nset key top right\n";
  for (int m = 0; m < 2; ++m) {
    const int n = static_cast<int>(rows[m].size());
    if (n == 0) continue;
    const double sigma = std::sqrt(sum2[m] / n);  // per coordinate
    const double width = std::max(sigma / 5, 1e-6);
    char text[900];
    std::snprintf(
        text, sizeof(text),
        "set title 'ring %d: %d corners, RMS per coordinate %.3f px'\n"
        "set xlabel 'residual coordinate (px)'\nset ylabel 'count'\n"
        "set xrange [%g:%g]\nbin(x) = %g * floor(x / %g + 0.5)\n"
        "plot $r%d using (bin($1)):(1.0) smooth freq with boxes title 'residuals', "
        "%d * %g / (%g * sqrt(2 * pi)) * exp(-x * x / (2 * %g)) with lines lw 2 "
        "title 'Gaussian of that RMS'\n",
        m + 1, n / 2, sigma, -5 * sigma,
        5 * sigma, width, width, m + 1, n, width, sigma, sigma * sigma);
    body += Datablock("r" + std::to_string(m + 1), rows[m]) + text;
  }
  body += "unset multiplot\n";
  return Plot(dir, "residual_histograms.png", body, note);
}

std::string PerImageRms(const std::string& dir, const ReportInput& in, std::string* note) {
  const int n_images = static_cast<int>(in.observations->images.size());
  std::vector<double> sum2[2], count[2];
  for (int m = 0; m < 2; ++m) {
    sum2[m].assign(n_images, 0);
    count[m].assign(n_images, 0);
  }
  for (const auto& r : in.result->residuals) {
    if (r.image < 0 || r.image >= n_images) continue;
    sum2[r.mirror - 1][r.image] += r.residual.squaredNorm();
    count[r.mirror - 1][r.image] += 1;
  }
  std::vector<std::vector<double>> rows;
  for (int i = 0; i < n_images; ++i) {
    rows.push_back({static_cast<double>(i),
                    count[0][i] ? std::sqrt(sum2[0][i] / count[0][i]) : 0.0,
                    count[1][i] ? std::sqrt(sum2[1][i] / count[1][i]) : 0.0});
  }
  const std::string body = Datablock("rms", rows) +
                           "set style data histograms\nset style histogram clustered\n"
                           "set style fill solid 0.7\nset xlabel 'image index'\n"
                           "set ylabel 'residual RMS (px)'\nset key top right\n"
                           "set title 'residual RMS per image'\n"
                           "plot $rms using 2:xtic(int($1) % 5 == 0 ? sprintf('%d', $1) : '') "
                           "title 'ring 1', '' using 3 title 'ring 2'\n";
  return Plot(dir, "per_image_rms.png", body, note);
}

std::string UncertaintyMap(const std::string& dir, const ReportInput& in, double range_mm,
                           std::string* note) {
  const std::vector<calib::PointUncertainty> map =
      calib::ProjectionUncertaintyMap(*in.result, range_mm);
  if (map.empty()) {
    *note = "no stereo-band point is seen in both rings at this range";
    return "";
  }
  std::vector<std::vector<double>> rows;
  for (const auto& p : map) {
    const Eigen::Vector3d& x = p.point_in_cam;
    rows.push_back({std::atan2(x.y(), x.x()) * 180 / M_PI,
                    std::atan2(x.z(), x.head<2>().norm()) * 180 / M_PI, p.in_mirror1_px[0],
                    p.in_mirror1_px[1]});
  }
  char name[64];
  std::snprintf(name, sizeof(name), "uncertainty_%.0fmm.png", range_mm);
  char title[256];
  std::snprintf(title, sizeof(title),
                "set multiplot layout 1,2 title 'sigma of projection (px) of points at %.2f m "
                "held in mirror 1''s body'\n",
                range_mm / 1000);
  const std::string body =
      Datablock("u", rows) + title +
      "set xlabel 'azimuth (deg)'\nset ylabel 'direction from C above its xy plane (deg)'\n"
      "set palette rgbformulae 22,13,-31\nset cblabel 'px'\nunset key\n"
      "set title 'ring 1 (mirror 1)'\nplot $u using 1:2:3 with points pt 5 ps 0.6 palette\n"
      "set title 'ring 2 (mirror 2)'\nplot $u using 1:2:4 with points pt 5 ps 0.6 palette\n"
      "unset multiplot\n";
  return Plot(dir, name, body, note);
}

}  // namespace omni::report
