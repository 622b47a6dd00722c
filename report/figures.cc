#include "report/figures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/profile_comparison.h"
#include "calib/projection_uncertainty.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "report/gnuplot.h"

namespace omni::report {
namespace {

// The first readable frame, darkened and grey (colour drawings stand out on it), or a dark
// canvas of the model's size.
cv::Mat Canvas(const ReportInput& in) {
  const RigParams& rig = in.result->estimate.rig;
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
                 std::string* note, int height = 420) {
  // noenhanced: names such as kalibr_aprilgrid are printed as written, not with subscripts.
  const std::string script = "set terminal pngcairo noenhanced size 900," +
                             std::to_string(height) + " font 'sans,10'\nset output '" + dir + "/" + name + "'\n" + body;
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
  for (const auto& r : in.result->residuals.corners) sizes.push_back(r.residual.norm());
  const double p95 = std::max(Percentile(sizes, 0.95), 1e-6);
  const double scale = 15.0 / p95;  // the 95th percentile drawn 15 px long
  for (const auto& r : in.result->residuals.corners) {
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
  for (const auto& r : in.result->residuals.corners) {
    cv::circle(canvas, {static_cast<int>(std::lround(r.pixel.x())),
                        static_cast<int>(std::lround(r.pixel.y()))},
               1, r.mirror == 1 ? cv::Scalar(80, 220, 80) : cv::Scalar(255, 120, 255), -1);
  }
  for (const auto& r : in.result->residuals.rejected) {
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
  for (const auto& r : in.result->residuals.corners) {
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

namespace {

// Residual RMS per ring of the residuals grouped by `group_of` (0..n-1; others left out), as
// clustered bars: rows (index, ring 1 RMS, ring 2 RMS).
template <typename GroupOf>
std::vector<std::vector<double>> RmsByGroup(const ReportInput& in, int n, GroupOf group_of) {
  std::vector<double> sum2[2], count[2];
  for (int m = 0; m < 2; ++m) {
    sum2[m].assign(n, 0);
    count[m].assign(n, 0);
  }
  for (const auto& r : in.result->residuals.corners) {
    const int g = group_of(r);
    if (g < 0 || g >= n) continue;
    sum2[r.mirror - 1][g] += r.residual.squaredNorm();
    count[r.mirror - 1][g] += 1;
  }
  std::vector<std::vector<double>> rows;
  for (int g = 0; g < n; ++g) {
    rows.push_back({static_cast<double>(g),
                    count[0][g] ? std::sqrt(sum2[0][g] / count[0][g]) : 0.0,
                    count[1][g] ? std::sqrt(sum2[1][g] / count[1][g]) : 0.0});
  }
  return rows;
}

std::string RmsBars(const std::string& dir, const std::string& name, const std::string& what,
                    const std::vector<std::string>& labels,
                    const std::vector<std::vector<double>>& rows, std::string* note) {
  return Plot(dir, name, RmsBarsScript(what, labels, rows), note);
}

}  // namespace

std::string RmsBarsScript(const std::string& what, const std::vector<std::string>& labels,
                          const std::vector<std::vector<double>>& rows) {
  // From 0 to above the largest bar (room for the key): bars are read against 0, and a range
  // that gnuplot's autoscale starts elsewhere makes a small RMS look large.
  double largest = 0;
  for (const auto& row : rows) largest = std::max({largest, row[1], row[2]});
  std::string data = "$rms << EOD\n";
  char line[160];
  for (size_t g = 0; g < rows.size(); ++g) {
    std::string label = g < labels.size() ? labels[g] : "";
    std::replace(label.begin(), label.end(), '"', '\'');
    std::snprintf(line, sizeof line, "%zu %.9g %.9g \"%s\"\n", g, rows[g][1], rows[g][2],
                  label.c_str());
    data += line;
  }
  data += "EOD\n";
  char range[80];
  std::snprintf(range, sizeof range, "set yrange [0:%.6g]\n", largest > 0 ? 1.25 * largest : 1.0);
  // Labels wider than their bars' share of the 900 px plot (~6 px a character at 10 pt) are
  // turned, so that neighbours do not overlap.
  size_t widest = 0;
  for (const std::string& l : labels) widest = std::max(widest, l.size());
  const bool turn = !rows.empty() && widest * 6 > 0.8 * 800 / rows.size();
  return data + (turn ? "set xtics rotate by 25 right\nset bmargin 7\n" : "") +
         "set style data histograms\nset style histogram clustered\n"
                "set style fill solid 0.7\nset xlabel '" + what + "'\n"
                "set ylabel 'residual RMS (px)'\nset key top right\n" + range +
                "set title 'residual RMS per " + what + "'\n"
                "plot $rms using 2:xtic(stringcolumn(4)) title 'ring 1', '' using 3 title 'ring 2'\n";
}

std::string PerImageRms(const std::string& dir, const ReportInput& in, std::string* note) {
  const auto rows = RmsByGroup(in, static_cast<int>(in.observations->images.size()),
                               [](const calib::CornerResidual& r) { return r.image; });
  // Every image's index up to 20 images, then every k-th (about 20 labels).
  const size_t every = std::max<size_t>(1, (rows.size() + 19) / 20);
  std::vector<std::string> labels;
  for (size_t i = 0; i < rows.size(); ++i) labels.push_back(i % every == 0 ? std::to_string(i) : "");
  return RmsBars(dir, "per_image_rms.png", "image", labels, rows, note);
}

std::string PerTargetRms(const std::string& dir, const ReportInput& in, std::string* note) {
  if (in.targets.empty()) {
    *note = "no targets";
    return "";
  }
  const auto rows = RmsByGroup(in, static_cast<int>(in.targets.size()),
                               [](const calib::CornerResidual& r) { return r.target; });
  std::vector<std::string> labels;
  for (const TargetSpec& t : in.targets) labels.push_back(TargetName(t));
  return RmsBars(dir, "per_target_rms.png", "target", labels, rows, note);
}

std::string CoverageAngles(const std::string& dir, const ReportInput& in, std::string* note) {
  const RigModel model(in.result->estimate.rig);
  std::vector<std::vector<double>> corners[2], band[2];
  auto angles = [&](const Eigen::Vector2d& pixel) -> std::optional<std::vector<double>> {
    const auto ray = model.Unproject(pixel);
    if (!ray) return std::nullopt;
    const Eigen::Vector3d& d = ray->ray.direction;
    return std::vector<double>{std::atan2(d.y(), d.x()) * 180 / M_PI,
                               std::atan2(d.z(), d.head<2>().norm()) * 180 / M_PI};
  };
  for (const auto& r : in.result->residuals.corners) {
    if (const auto a = angles(r.pixel)) corners[r.mirror - 1].push_back(*a);
  }
  const int rings = in.result->estimate.rig.Paths();
  for (const BandPoint& p : StereoBandPoints(model, 1000)) {
    for (int m = 0; m < rings; ++m) {
      if (const auto a = angles(p.pixel[m])) band[m].push_back(*a);
    }
  }
  if (corners[0].empty() && corners[1].empty()) {
    *note = "no corner's ray could be traced";
    return "";
  }
  std::string body = std::string("set multiplot layout 1,") + (rings == 1 ? "1" : "2") +
                     " title 'where the used corners were seen (dots) over " +
                     (rings == 1 ? "the view of the ring" : "the stereo band") +
                     " at 1 m (grey)'\nset xlabel 'azimuth (deg)'\n"
                     "set ylabel 'ray elevation (deg)'\nset xrange [-180:180]\nunset key\n";
  for (int m = 0; m < rings; ++m) {
    const std::string c = "c" + std::to_string(m + 1), b = "b" + std::to_string(m + 1);
    body += Datablock(c, corners[m].empty() ? std::vector<std::vector<double>>{{0, 0}} : corners[m]) +
            Datablock(b, band[m].empty() ? std::vector<std::vector<double>>{{0, 0}} : band[m]) +
            "set title 'ring " + std::to_string(m + 1) + "'\nplot $" + b +
            " using 1:2 with points pt 5 ps 0.5 lc rgb '#dddddd', $" + c +
            " using 1:2 with points pt 7 ps 0.3 lc rgb '" + (m == 0 ? "#1a9850" : "#c51b7d") +
            "'\n";
  }
  body += "unset multiplot\n";
  return Plot(dir, "coverage_angles.png", body, note);
}

std::vector<std::string> OutlierThumbnails(const std::string& dir, const ReportInput& in,
                                           int count) {
  std::map<int, std::vector<Eigen::Vector2d>> by_image;
  for (const auto& r : in.result->residuals.rejected) by_image[r.image].push_back(r.pixel);
  std::vector<std::pair<int, int>> order;  // (count, image)
  for (const auto& [image, pixels] : by_image) {
    order.push_back({static_cast<int>(pixels.size()), image});
  }
  std::sort(order.rbegin(), order.rend());
  std::vector<std::string> out;
  for (const auto& [n, image] : order) {
    if (static_cast<int>(out.size()) >= count) break;
    if (image < 0 || image >= static_cast<int>(in.image_paths.size())) continue;
    cv::Mat frame = cv::imread(in.image_paths[image], cv::IMREAD_COLOR);
    if (frame.empty()) continue;
    cv::Rect box;
    for (const Eigen::Vector2d& p : by_image[image]) {
      const cv::Rect one(static_cast<int>(p.x()) - 40, static_cast<int>(p.y()) - 40, 81, 81);
      box = box.empty() ? one : (box | one);
    }
    box &= cv::Rect(0, 0, frame.cols, frame.rows);
    if (box.empty()) continue;
    for (const Eigen::Vector2d& p : by_image[image]) {
      cv::drawMarker(frame, {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))},
                     {0, 0, 255}, cv::MARKER_TILTED_CROSS, 9, 1);
    }
    cv::Mat crop = frame(box).clone();
    if (crop.cols > 480) cv::resize(crop, crop, {}, 480.0 / crop.cols, 480.0 / crop.cols, cv::INTER_AREA);
    const std::string name = "outliers_" + std::to_string(image) + ".png";
    if (cv::imwrite(dir + "/" + name, crop)) out.push_back(name);
  }
  return out;
}

double LargestUncertaintyPx(const std::vector<calib::PointUncertainty>& map) {
  double largest = 0;
  for (const auto& p : map) largest = std::max({largest, p.in_mirror1_px[0], p.in_mirror1_px[1]});
  return largest;
}

std::string UncertaintyMapScript(const std::vector<calib::PointUncertainty>& map,
                                 double range_mm, double cb_max_px, int rings) {
  std::vector<std::vector<double>> rows;
  for (const auto& p : map) {
    const Eigen::Vector3d& x = p.point_in_cam;
    rows.push_back({std::atan2(x.y(), x.x()) * 180 / M_PI,
                    std::atan2(x.z(), x.head<2>().norm()) * 180 / M_PI, p.in_mirror1_px[0],
                    p.in_mirror1_px[1]});
  }
  char head[512];
  std::snprintf(head, sizeof(head),
                "set multiplot layout 1,%d title 'sigma of projection (px) of points at %.2f m "
                "held in mirror 1''s body'\n"
                "set cbrange [0:%.6g]\n",
                rings == 1 ? 1 : 2, range_mm / 1000, cb_max_px > 0 ? cb_max_px : 1.0);
  const std::string axes =
      "set xlabel 'azimuth (deg)'\nset ylabel 'direction from C above its xy plane (deg)'\n"
      "set palette rgbformulae 22,13,-31\nset cblabel 'sigma (px)'\nunset key\n";
  if (rings == 1) {  // a single mirror: its one ring, with the colour bar
    return Datablock("u", rows) + head + axes +
           "set title 'ring 1 (the mirror)'\nplot $u using 1:2:3 with points pt 5 ps 0.6 palette\n"
           "unset multiplot\n";
  }
  // One colour scale for both rings (and both ranges: the caller's cb_max_px), its bar drawn
  // once, beside ring 2.
  return Datablock("u", rows) + head + axes +
         "unset colorbox\n"
         "set title 'ring 1 (mirror 1)'\nplot $u using 1:2:3 with points pt 5 ps 0.6 palette\n"
         "set colorbox\n"
         "set title 'ring 2 (mirror 2)'\nplot $u using 1:2:4 with points pt 5 ps 0.6 palette\n"
         "unset multiplot\n";
}

std::string UncertaintyMap(const std::string& dir,
                           const std::vector<calib::PointUncertainty>& map, double range_mm,
                           double cb_max_px, int rings, std::string* note) {
  if (map.empty()) {
    *note = rings == 1 ? "no point at this range is seen in the ring"
                       : "no stereo-band point is seen in both rings at this range";
    return "";
  }
  char name[64];
  std::snprintf(name, sizeof(name), "uncertainty_%.0fmm.png", range_mm);
  return Plot(dir, name, UncertaintyMapScript(map, range_mm, cb_max_px, rings), note);
}

std::string MeasuredProfileScript(const calib::CalibrationResult& result, int mirror) {
  const RigParams& rig = result.estimate.rig;
  const std::optional<MeasuredProfile>& measured = rig.measured_profile[mirror - 1];
  if (!measured) return "";
  // The scan's piston is the mirror's axial offset (not a profile term): the points are drawn
  // without it, as the fit sees them.
  const double theta = measured->scan.empty() ? 0.0 : measured->scan.front().theta_rad;
  const std::vector<calib::ProfileSample> samples =
      calib::CompareWithMeasured(rig, result, mirror, theta, 121);
  std::vector<std::vector<double>> points, curves;
  for (const ProfileScanPoint& p : measured->scan) {
    if (p.theta_rad != theta) break;  // the first scan line
    points.push_back({p.r_mm, 1000 * (p.sag_mm - measured->fit.piston_mm)});
  }
  for (const calib::ProfileSample& s : samples) {
    curves.push_back({s.r_mm, 1000 * s.measured_mm, 1000 * s.calibrated_mm, 1000 * s.difference_mm,
                      1000 * s.sigma_mm});
  }
  std::string scan_file = measured->scan_file;  // in a gnuplot '...' string: ' as ''
  for (size_t at = scan_file.find('\''); at != std::string::npos; at = scan_file.find('\'', at + 2)) {
    scan_file.insert(at, 1, '\'');
  }
  // One radius axis for both panels: the scan line's and the profile's radii.
  if (samples.empty()) return "";
  double r_lo = samples.front().r_mm, r_hi = samples.back().r_mm;
  for (const auto& p : points) r_lo = std::min(r_lo, p[0]), r_hi = std::max(r_hi, p[0]);
  char text[1400];
  std::snprintf(
      text, sizeof(text),
      "set multiplot layout 2,1\nset key top left\nset grid\nset xrange [%g:%g]\n"
      "set title 'mirror %d: profile along azimuth %.0f deg (scan %s, stated accuracy %.3g um, "
      "fit residual %.3g um PV)'\n"
      "set ylabel 'sag over the conic (um)'\n"
      "plot %s$curves using 1:2 with lines lw 2 lc rgb '#1f77b4' title 'measured (the scan''s fit)', "
      "'' using 1:3 with lines lw 2 dt 2 lc rgb '#d62728' title 'calibrated'\n"
      "set title 'calibrated minus measured, with its 1-sigma band'\n"
      "set xlabel 'mirror radius (mm)'\nset ylabel 'difference (um)'\n"
      "plot $curves using 1:($4-$5):($4+$5) with filledcurves fc rgb '#c6dbef' title '1 sigma', "
      "'' using 1:4 with lines lw 2 lc rgb '#d62728' title 'difference', 0 with lines lc rgb "
      "'#444444' notitle\nunset multiplot\n",
      r_lo, r_hi, mirror, theta * 180 / M_PI, scan_file.c_str(), 1000 * measured->accuracy_mm,
      1000 * measured->fit.residual_pv_mm,
      points.empty() ? ""
                     : "$points using 1:2 with points pt 7 ps 0.4 lc rgb '#999999' title 'scan "
                       "(piston removed)', ");
  // A model read back carries the scan's fit, not its points (io/measured_profile.h).
  return (points.empty() ? "" : Datablock("points", points)) + Datablock("curves", curves) + text;
}

std::string MeasuredProfilePlot(const std::string& dir, const ReportInput& in, int mirror,
                                std::string* note) {
  const std::string script = MeasuredProfileScript(*in.result, mirror);
  if (script.empty()) return "";
  return Plot(dir, "profile_mirror" + std::to_string(mirror) + ".png", script, note, 640);
}

}  // namespace omni::report
