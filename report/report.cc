#include "report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "calib/projection_uncertainty.h"
#include "io/file_util.h"
#include "model/input_error.h"
#include "model/model_compare.h"
#include "model/rig_model.h"
#include "model/rig_parameters.h"
#include "model/triangulation.h"
#include "report/figures.h"

namespace omni::report {
namespace {

std::string Escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Format(const char* format, double value) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, value);
  return buf;
}

// A figure, or the note saying why it is missing.
std::string Figure(const std::string& file, const std::string& note, const std::string& caption) {
  if (file.empty()) return "<p class=\"missing\">(" + Escape(caption) + ": " + Escape(note) + ")</p>\n";
  return "<figure><img src=\"" + Escape(file) + "\" alt=\"" + Escape(caption) +
         "\"><figcaption>" + Escape(caption) + "</figcaption></figure>\n";
}

std::string Summary(const ReportInput& in) {
  const calib::CalibrationResult& r = *in.result;
  std::ostringstream out;
  int used[2] = {0, 0};
  for (const auto& c : r.residuals.corners) ++used[c.mirror - 1];
  int left_out[2] = {0, 0};
  for (const auto& c : r.residuals.rejected) ++left_out[std::clamp(c.mirror, 1, 2) - 1];
  const double worst = std::max(r.residuals.per_mirror_rms_px[0], r.residuals.per_mirror_rms_px[1]);
  out << "<p class=\"verdict\">" << (r.solve.converged ? "Converged" : "NOT converged") << ": "
      << r.residuals.n_observations << " corners in " << in.observations->images.size()
      << " images, reprojection RMS " << Format("%.3f", r.residuals.rms_px) << " px (worst ring "
      << Format("%.3f", worst) << " px), " << r.estimate.names.size() << " parameters refined, "
      << r.uncertainty.unobservable.size() << " not determined; solved in "
      << Format("%.2f", in.solve_seconds) << " s.</p>\n";
  out << "<table><tr><th>residual group</th><th>used</th><th>left out</th><th>RMS (px)</th>"
         "<th>noise sigma per axis (px)</th></tr>\n";
  for (const auto& v : r.uncertainty.variance_components) {
    int ring = v.group == "corners ring 1" ? 1 : v.group == "corners ring 2" ? 2 : 0;
    out << "<tr><td>" << Escape(v.group) << "</td><td>" << v.count << "</td><td>"
        << (ring ? std::to_string(left_out[ring - 1]) : std::to_string(r.residuals.n_lip_rejected))
        << "</td><td>"
        << Format("%.3f", ring ? r.residuals.per_mirror_rms_px[ring - 1] : r.residuals.lip_rms_px)
        << "</td><td>" << Format("%.3f", v.sigma_px) << "</td></tr>\n";
  }
  out << "</table>\n";
  return out.str();
}

std::string ParameterTable(const calib::CalibrationResult& r) {
  std::ostringstream out;
  out << "<table><tr><th>parameter</th><th>value</th><th>sigma</th><th>unit</th></tr>\n";
  for (size_t i = 0; i < r.estimate.names.size(); ++i) {
    const RigParameter* p = FindRigParameter(r.estimate.names[i]);
    const double value = p ? DisplayValue(*p, r.estimate.values(i)) : r.estimate.values(i);
    const double sigma =
        p ? std::abs(DisplayValue(*p, r.uncertainty.sigma(i))) : r.uncertainty.sigma(i);
    out << "<tr><td>" << Escape(r.estimate.names[i]) << "</td><td>" << Format("%.6g", value)
        << "</td><td>" << Format("%.3g", sigma) << "</td><td>" << (p ? DisplayUnit(*p) : "")
        << "</td></tr>\n";
  }
  out << "</table>\n";
  if (!r.uncertainty.considered.empty()) {
    out << "<p>Held but not known exactly (their sigma is carried into the table's):";
    for (const auto& c : r.uncertainty.considered) {
      out << " " << Escape(c.name) << " = " << Format("%.3g", c.value) << " &plusmn; "
          << Format("%.3g", c.sigma) << ";";
    }
    out << "</p>\n";
  }
  if (!r.uncertainty.unobservable.empty()) {
    out << "<p>Not determined (held, no number given):</p><ul>\n";
    for (const auto& u : r.uncertainty.unobservable) {
      out << "<li>" << Escape(u.name) << ": " << Escape(u.hint) << "</li>\n";
    }
    out << "</ul>\n";
  }
  if (!r.solve.notes.empty()) {
    out << "<ul>\n";
    for (const auto& n : r.solve.notes) out << "<li>" << Escape(n) << "</li>\n";
    out << "</ul>\n";
  }
  return out.str();
}

// True for a tilt (rx, ry of a mirror or the reflex plane) or what a rotation of the camera
// against the bodies moves with one (the principal point, the decentres): the table's
// RotationValley.
bool InRotationValley(const std::string& name) {
  const RigParameter* p = FindRigParameter(name);
  return p && name == p->name && p->valley != RotationValley::kNone;
}

std::string Correlations(const calib::CalibrationResult& r) {
  struct Pair {
    double value;
    size_t i, j;
  };
  std::vector<Pair> pairs;
  const size_t n = r.estimate.names.size();
  if (static_cast<size_t>(r.uncertainty.correlation.rows()) != n) return "";
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) pairs.push_back({r.uncertainty.correlation(i, j), i, j});
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return std::abs(a.value) > std::abs(b.value); });
  std::ostringstream out;
  out << "<table><tr><th>parameters</th><th>correlation</th><th></th></tr>\n";
  for (size_t k = 0; k < std::min<size_t>(10, pairs.size()); ++k) {
    const Pair& p = pairs[k];
    const bool valley =
        InRotationValley(r.estimate.names[p.i]) && InRotationValley(r.estimate.names[p.j]);
    out << "<tr><td>" << Escape(r.estimate.names[p.i]) << " ~ " << Escape(r.estimate.names[p.j])
        << "</td><td>" << Format("%+.3f", p.value) << "</td><td>"
        << (valley ? "the camera-rotation valley: turning C against the mirror bodies moves "
                     "these together"
                   : "")
        << "</td></tr>\n";
  }
  out << "</table>\n";
  return out.str();
}

std::string LeftOut(const ReportInput& in) {
  std::map<std::pair<int, std::string>, int> count;  // (image, reason)
  for (const auto& r : in.result->residuals.rejected) ++count[{r.image, r.reason}];
  if (count.empty()) return "<p>No corner was left out.</p>\n";
  std::ostringstream out;
  out << "<table><tr><th>image</th><th>reason</th><th>corners</th></tr>\n";
  const auto& images = in.observations->images;
  for (const auto& [key, n] : count) {
    const std::string file = key.first >= 0 && key.first < static_cast<int>(images.size())
                                 ? images[key.first].file
                                 : "?";
    out << "<tr><td>" << Escape(file) << "</td><td>" << Escape(key.second) << "</td><td>" << n
        << "</td></tr>\n";
  }
  out << "</table>\n";
  return out.str();
}

// Triangulation sigma (mm) of points of the stereo band at 1, 2 and 4 m held in mirror 1's body
// (model/triangulation.h with the calibration's covariance), at the corners' estimated noise:
// the RMS over the band of sqrt(trace Sigma), in total and the model's part alone.
std::string TriangulationTable(const calib::CalibrationResult& r) {
  const RigModel model(r.estimate.rig);
  const Triangulator triangulator(model);
  TriangulationOptions options;
  options.reference = ReferenceBody::kMirror1;
  options.model_covariance = true;
  for (const auto& v : r.uncertainty.variance_components) {
    if (v.group == "corners ring 1") options.sigma_px = v.sigma_px;
    if (v.group == "corners ring 2") options.sigma_px_ring2 = v.sigma_px;
  }
  std::ostringstream out;
  out << "<p>Points triangulated from both rings (midpoint), held in mirror 1's body, with pixel "
         "noise of "
      << Format("%.3f", options.sigma_px) << " px in ring 1 and "
      << Format("%.3f", options.sigma_px_ring2)
      << " px in ring 2 (the corners' estimated noise) and the calibration's covariance; RMS over "
         "the stereo band of sqrt(trace Sigma):</p>\n<table><tr><th>range</th><th>points</th>"
         "<th>sigma (mm)</th><th>from the model alone (mm)</th></tr>\n";
  constexpr int kStride = 4;  // every 4th band point: an RMS over a smooth field
  for (double range : {1000.0, 2000.0, 4000.0}) {
    const std::vector<BandPoint> band = StereoBandPoints(model, range);
    double total2 = 0, model2 = 0;
    int n = 0;
    for (size_t i = 0; i < band.size(); i += kStride) {
      const auto p = triangulator.Triangulate(band[i].pixel[0], band[i].pixel[1], options);
      if (!p) continue;
      total2 += p->covariance.trace();
      model2 += p->model_covariance.trace();
      ++n;
    }
    out << "<tr><td>" << Format("%.0f", range / 1000) << " m</td><td>" << n << "</td><td>"
        << (n ? Format("%.2f", std::sqrt(total2 / n)) : "-") << "</td><td>"
        << (n ? Format("%.2f", std::sqrt(model2 / n)) : "-") << "</td></tr>\n";
  }
  out << "</table>\n";
  return out.str();
}

// The projection uncertainty's summary at 1 m: over the stereo band, or over a single mirror's
// one ring.
std::string ProjectionParagraph(const calib::ProjectionUncertainty& at_1m, int rings) {
  if (rings == 1) {
    return "<p>From the covariance: the RMS over the ring's view at 1 m of the predicted sigma of "
           "projection, points held in the mirror's body, is " +
           Format("%.3f", at_1m.in_mirror1_px[0]) + " px (points held in C: " +
           Format("%.3f", at_1m.in_cam_px[0]) + " px).</p>\n";
  }
  return "<p>From the covariance: the RMS over the stereo band at 1 m of the predicted sigma of "
         "projection, points held in mirror 1's body, is " +
         Format("%.3f", at_1m.in_mirror1_px[0]) + " px in ring 1 and " +
         Format("%.3f", at_1m.in_mirror1_px[1]) + " px in ring 2 (points held in C: " +
         Format("%.3f", at_1m.in_cam_px[0]) + " / " + Format("%.3f", at_1m.in_cam_px[1]) +
         " px).</p>\n";
}

std::string Tolerances(const std::vector<design::ToleranceCheck>& checks) {
  std::ostringstream out;
  out << "<table><tr><th>check</th><th>value</th><th>sigma</th><th>limit</th><th>verdict</th>"
         "</tr>\n";
  for (const auto& c : checks) {
    const bool rad = c.unit == "rad";
    const double scale = rad ? 180 / M_PI : 1;
    const char* unit = rad ? " deg" : " mm";
    out << "<tr><td>" << Escape(c.name) << "</td><td>" << Format("%.4g", c.value * scale) << unit
        << "</td><td>" << (c.sigma ? Format("%.2g", *c.sigma * scale) + unit : "-") << "</td><td>"
        << Format("%.4g", c.limit * scale) << unit << "</td><td>" << design::VerdictName(c.verdict)
        << "</td></tr>\n";
    // Which way to move a part that fails; a value the calibration cannot tell from the
    // camera's rotation.
    for (const std::string& note : {design::Correction(c), design::RotationValleyNote(c)}) {
      if (!note.empty()) out << "<tr><td></td><td colspan=\"4\">" << Escape(note) << "</td></tr>\n";
    }
  }
  out << "</table>\n<p>PASS: within the limit even at the value plus its confidence sigmas; "
         "FAIL: beyond it even at the value minus them; UNDECIDED: more data would decide.</p>\n";
  return out.str();
}

const char kStyle[] =
    "body{font-family:sans-serif;max-width:1000px;margin:1em auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 8px;"
    "text-align:left}img{max-width:100%}.verdict{font-size:1.15em;font-weight:bold}"
    ".missing{color:#a00}figure{margin:1em 0}figcaption{color:#555}";

}  // namespace

// Each mirror's profile (calib ProfileDecision): freed or held, and the corners' mean radial
// residual per band of the mirror's radius before the decision and at the end. A machining error
// the model lacks shows as a smooth run of means many standard errors from zero.
// The posts of the rig's mount (model/mount.h): where they stand and the azimuths they hide.
std::string MountSection(const RigParams& rig) {
  const Mount& m = rig.mount;
  if (!m.present) return "<p>No mount in the model: nothing hides part of the rings.</p>\n";
  std::string azimuths, widths;
  double wide_deg = 0;  // the azimuth all posts hide
  for (size_t i = 0; i < m.azimuths.size(); ++i) {
    azimuths += (azimuths.empty() ? "" : ", ") + Format("%.1f", m.azimuths[i] * 180 / M_PI);
    widths += (widths.empty() ? "" : ", ") + Format("%.1f", m.WidthOf(i));
    // A square post seen from the axis: its near face's corners at radius - width / 2.
    wide_deg += 2 * std::atan2(0.5 * m.WidthOf(i), m.radius - 0.5 * m.WidthOf(i)) * 180 / M_PI;
  }
  const std::string sides = m.EqualWidths() ? Format("%.1f", m.WidthOf(0)) : widths;
  return "<p>" + std::to_string(m.azimuths.size()) + " posts of " + sides +
         " mm at " + Format("%.1f", m.radius) + " mm from the axis of mirror " +
         std::to_string(MirrorIndex(m.body)) + "'s body, z " + Format("%.1f", m.z_min) + " to " +
         Format("%.1f", m.z_max) + " mm, at azimuths " + azimuths + " deg. Together they hide about " +
         Format("%.1f", wide_deg) + " deg of azimuth in both rings (" +
         Format("%.1f", 100 * wide_deg / 360) +
         "% of the view): paths through a post are invalid, so projection, panoramas, depth and "
         "the check leave those sectors out, and no corner is expected there.</p>\n";
}

// `plots`, `notes`: each mirror's measured-profile figure (MeasuredProfilePlot) or why it is missing.
std::string ProfileSection(const calib::CalibrationResult& r, const std::string (&plots)[2],
                           const std::string (&notes)[2]) {
  std::ostringstream out;
  bool any = false;
  for (int m = 0; m < 2; ++m) {
    const calib::ProfileDecision& d = r.residuals.profile[m];
    if (d.pattern_before.empty()) continue;
    any = true;
    out << "<h3>Mirror " << m + 1 << "</h3>\n<p>Profile " << (d.freed ? "refined" : "held (its tolerance carried into the sigmas)")
        << "; the corners fill " << d.bins_covered << " of " << d.bins << " bands of the radii they reach on it, "
        << Format("%.1f", d.r_min) << "-" << Format("%.1f", d.r_max)
        << " mm. Radial residual pattern (chi<sup>2</sup> per band, ~1 without a pattern): "
        << Format("%.2f", d.pattern_chi2_before) << " before, " << Format("%.2f", d.pattern_chi2_after)
        << " at the end.</p>\n<table><tr><th>mirror radius (mm)</th><th>corners</th>"
        << "<th>mean radial residual before (px)</th><th>at the end (px)</th></tr>\n";
    for (size_t b = 0; b < d.pattern_before.size(); ++b) {
      const auto& before = d.pattern_before[b];
      out << "<tr><td>" << Format("%.1f", before.r_lo) << "-" << Format("%.1f", before.r_hi)
          << "</td><td>" << before.count << "</td><td>" << Format("%+.4f", before.mean_px)
          << " &plusmn; " << Format("%.4f", before.sem_px) << "</td><td>";
      if (b < d.pattern_after.size()) {
        out << Format("%+.4f", d.pattern_after[b].mean_px) << " &plusmn; "
            << Format("%.4f", d.pattern_after[b].sem_px);
      }
      out << "</td></tr>\n";
    }
    out << "</table>\n";
    if (d.measured) {
      out << Figure(plots[m], notes[m],
                    "mirror " + std::to_string(m + 1) +
                        "'s profile against the radius: measured (the scan's fit), calibrated, "
                        "and their difference with its 1-sigma band");
    }
  }
  return any ? out.str() : "<p>Profiles left out of this calibration (profile: off).</p>\n";
}

std::string WriteReport(const std::string& dir, const ReportInput& in) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw InputError(dir + ": cannot create the report folder (" + ec.message() + ")");
  }
  std::string note[8];
  auto status = [&](const char* now) {
    if (in.status) in.status(now);
  };
  status("residual vectors");
  const std::string vectors = ResidualVectors(dir, in, &note[0]);
  status("coverage");
  const std::string coverage = CoverageImage(dir, in, &note[1]);
  status("residual histograms");
  const std::string histograms = ResidualHistograms(dir, in, &note[2]);
  status("residuals per image and target");
  const std::string per_image = PerImageRms(dir, in, &note[3]);
  const std::string per_target = PerTargetRms(dir, in, &note[6]);
  const std::string angles = CoverageAngles(dir, in, &note[7]);
  status("left-out corners");
  const std::vector<std::string> thumbnails = OutlierThumbnails(dir, in, 6);
  status("projection uncertainty");
  const std::vector<calib::PointUncertainty> map_1m =
      calib::ProjectionUncertaintyMap(*in.result, 1000);
  const std::vector<calib::PointUncertainty> map_far =
      calib::ProjectionUncertaintyMap(*in.result, in.range_mm);
  // Both maps, both rings on one colour scale: a colour means the same sigma everywhere.
  const double cb_max = std::max(LargestUncertaintyPx(map_1m), LargestUncertaintyPx(map_far));
  const int rings = in.result->estimate.rig.Paths();
  const std::string near = UncertaintyMap(dir, map_1m, 1000, cb_max, rings, &note[4]);
  const std::string far = UncertaintyMap(dir, map_far, in.range_mm, cb_max, rings, &note[5]);
  status("mirror profiles");
  std::string profile_plots[2], profile_notes[2];
  for (int m = 0; m < 2; ++m) profile_plots[m] = MeasuredProfilePlot(dir, in, m + 1, &profile_notes[m]);
  status("triangulation uncertainty");
  const calib::ProjectionUncertainty at_1m = calib::RmsOf(map_1m);

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
       << "<title>omnistereo calibration report</title><style>" << kStyle
       << "</style></head><body>\n<h1>Calibration report</h1>\n<p>session "
       << Escape(in.session) << "</p>\n"
       << Summary(in) << "<h2>Advice</h2>\n";
  const std::vector<std::string> advice = Advice(in);
  if (advice.empty()) {
    html << (in.result->estimate.rig.Single()
                 ? "<p>Nothing stands out: the session covers the ring.</p>\n"
                 : "<p>Nothing stands out: the session covers both rings.</p>\n");
  }
  html << "<ul>\n";
  for (const auto& a : advice) html << "<li>" << Escape(a) << "</li>\n";
  html << "</ul>\n<h2>Parameters</h2>\n"
       << ParameterTable(*in.result) << "<h2>Residuals</h2>\n"
       << Figure(histograms, note[2], "residual coordinates per ring against a Gaussian")
       << Figure(vectors, note[0], "residual vectors over the image")
       << Figure(per_image, note[3], "residual RMS per image")
       << Figure(per_target, note[6], "residual RMS per target") << "<h2>Mirror profiles</h2>\n"
       << ProfileSection(*in.result, profile_plots, profile_notes) << "<h2>Mount</h2>\n"
       << MountSection(in.result->estimate.rig) << "<h2>Coverage</h2>\n"
       << Figure(angles, note[7], "where the corners' rays point, per ring")
       << Figure(coverage, note[1], "where corners were seen (every image)")
       << "<h2>Projection uncertainty</h2>\n" << ProjectionParagraph(at_1m, rings)
       << Figure(near, note[4], "sigma of projection at 1 m")
       << Figure(far, note[5],
                 "sigma of projection at " + Format("%.2f", in.range_mm / 1000) + " m")
       << "<h2>Triangulation uncertainty</h2>\n"
       << (rings == 1 ? "<p>A single mirror gives one view per photo: nothing is triangulated "
                        "from one photo (the projection sigma above is what a ray carries).</p>\n"
                      : TriangulationTable(*in.result))
       << (in.tolerances.empty() ? ""
                                 : "<h2>Assembly tolerances</h2>\n" + Tolerances(in.tolerances))
       << "<h2>Strongest correlations</h2>\n"
       << Correlations(*in.result) << "<h2>Left out</h2>\n"
       << LeftOut(in);
  for (const std::string& t : thumbnails) {
    html << Figure(t, "", "left-out corners (red crosses) in image " +
                              t.substr(9, t.size() - 13));
  }
  html << "</body></html>\n";
  // "report/" given: report/index.html, not report//index.html.
  const std::string index = (!dir.empty() && dir.back() == '/' ? dir : dir + "/") + "index.html";
  io::WriteFileAtomically(index, html.str());
  return index;
}

}  // namespace omni::report
