// The report's figures, each written into the report's folder; each returns the file name (in
// that folder) or, where it could not be made, an empty name and *note saying why.
#pragma once

#include <string>
#include <vector>

#include "calib/projection_uncertainty.h"
#include "report/report.h"

namespace omni::report {

// Residual vectors of the final solve per ring over the first frame (scaled, coloured by size).
std::string ResidualVectors(const std::string& dir, const ReportInput& in, std::string* note);
// Where corners were seen (both rings, every image) and the left-out ones, over the first frame.
std::string CoverageImage(const std::string& dir, const ReportInput& in, std::string* note);
// Histograms of the residuals' coordinates per ring against the Gaussian of their RMS.
std::string ResidualHistograms(const std::string& dir, const ReportInput& in, std::string* note);
// Residual RMS per image and ring.
std::string PerImageRms(const std::string& dir, const ReportInput& in, std::string* note);
// Residual RMS per session target (named: TargetName) and ring.
std::string PerTargetRms(const std::string& dir, const ReportInput& in, std::string* note);
// The gnuplot script of those bar plots: rows (index, ring 1 RMS, ring 2 RMS), one x label per
// row; the y axis from 0 to above the largest bar.
std::string RmsBarsScript(const std::string& what, const std::vector<std::string>& labels,
                          const std::vector<std::vector<double>>& rows);
// Where the used corners' rays point, per ring: azimuth x elevation (deg) through the
// calibrated model, over the stereo band's outline at 1 m.
std::string CoverageAngles(const std::string& dir, const ReportInput& in, std::string* note);
// Up to `count` crops of frames around their left-out corners (marked), the images with the
// most first; the file names written.
std::vector<std::string> OutlierThumbnails(const std::string& dir, const ReportInput& in,
                                           int count);
// The predicted sigma of projection over each ring's stereo band (azimuth x elevation) for
// points at range_mm held in mirror 1's body (`map`: calib::ProjectionUncertaintyMap), both
// rings on one colour scale from 0 to cb_max_px (the report passes the largest over all its maps:
// LargestUncertaintyPx), with its colour bar. `rings` 1: a single mirror's one ring.
std::string UncertaintyMap(const std::string& dir,
                           const std::vector<calib::PointUncertainty>& map, double range_mm,
                           double cb_max_px, int rings, std::string* note);
std::string UncertaintyMapScript(const std::vector<calib::PointUncertainty>& map,
                                 double range_mm, double cb_max_px, int rings = 2);
double LargestUncertaintyPx(const std::vector<calib::PointUncertainty>& map);

// A measured mirror's profile against the radius (calib/profile_comparison.h), along its first
// scan line's azimuth: above, the scan's points on that line (where the model was read with its
// scan, not a written model's fit), the scan's fit and the calibrated
// profile (um); below, calibrated minus measured with its 1-sigma band. Empty, without a note,
// where mirror `mirror` (1, 2) was not measured.
std::string MeasuredProfilePlot(const std::string& dir, const ReportInput& in, int mirror,
                                std::string* note);
std::string MeasuredProfileScript(const calib::CalibrationResult& result, int mirror);

}  // namespace omni::report
