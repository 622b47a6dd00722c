#include "io/profile_scan_file.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <string_view>

#include "io/csv.h"

namespace omni::io {
namespace {

constexpr int kMinPointsInside = 10;

std::string Mm(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.4g", v);
  return text;
}

// The radii of one scan line inside the profile's radii, for the gap check.
struct ScanLine {
  double theta_deg = 0;
  long first_line = 0;
  std::vector<double> radii_inside;
};

void CheckGaps(const std::string& path, const ScanLine& line, const ProfileShape& shape,
               double max_gap) {
  std::vector<double> r = line.radii_inside;
  r.insert(r.begin(), shape.r_min);
  r.push_back(shape.r_max);
  for (size_t i = 1; i < r.size(); ++i) {
    if (r[i] - r[i - 1] > max_gap) {
      throw InputError(path + ": line " + std::to_string(line.first_line) + ": the scan line at " +
                       Mm(line.theta_deg) + " deg has no point between r " + Mm(r[i - 1]) +
                       " and " + Mm(r[i]) + " mm: expected gaps of at most " + Mm(max_gap) +
                       " mm over the profile's radii " + Mm(shape.r_min) + ".." + Mm(shape.r_max) +
                       " mm");
    }
  }
}

}  // namespace

std::vector<ProfileScanPoint> ReadProfileScan(const std::string& path, const ProfileShape& shape,
                                              const ProfileScanLimits& limits) {
  CsvReader reader(path, {"r_mm", "sag_mm"});
  const int theta_column = reader.ColumnIndex("theta_deg");
  const double max_gap =
      limits.max_gap_mm > 0 ? limits.max_gap_mm : (shape.r_max - shape.r_min) / 10;
  std::vector<ProfileScanPoint> scan;
  std::vector<ScanLine> lines;
  std::vector<double> row;
  int inside = 0;
  while (reader.ReadRow(&row)) {
    const std::string where = path + ": line " + std::to_string(reader.line()) + ": ";
    ProfileScanPoint p;
    p.r_mm = row[0];
    p.sag_mm = row[1];
    double theta_deg = 0;
    if (theta_column >= 0) {
      const std::string_view text = reader.Field(theta_column);
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), theta_deg);
      if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(theta_deg)) {
        throw InputError(where + "column 'theta_deg': expected a number (deg), got '" +
                         std::string(text) + "'");
      }
    }
    p.theta_rad = theta_deg * M_PI / 180;
    if (!std::isfinite(p.r_mm) || p.r_mm < limits.hole_mm || p.r_mm < 0 ||
        (limits.rim_mm > 0 && p.r_mm > limits.rim_mm)) {
      throw InputError(where + "r_mm " + Mm(p.r_mm) + ": expected a radius on the mirror, " +
                       Mm(limits.hole_mm) + ".." + Mm(limits.rim_mm) + " mm" +
                       (limits.hole_mm > 0 && p.r_mm < limits.hole_mm ? " (inside the hole)" : ""));
    }
    if (!std::isfinite(p.sag_mm) || std::abs(p.sag_mm) > limits.max_sag_mm) {
      throw InputError(where + "sag_mm " + Mm(p.sag_mm) + ": expected a departure from the conic " +
                       "of at most " + Mm(limits.max_sag_mm) +
                       " mm (is the design form removed, and the unit mm?)");
    }
    if (lines.empty() || theta_deg != lines.back().theta_deg) {
      lines.push_back(ScanLine{theta_deg, static_cast<long>(reader.line()), {}});
    } else if (!(p.r_mm > scan.back().r_mm)) {
      throw InputError(where + "r_mm " + Mm(p.r_mm) + " after " + Mm(scan.back().r_mm) +
                       ": expected increasing radii within a scan line (theta " + Mm(theta_deg) +
                       " deg)");
    }
    if (p.r_mm >= shape.r_min && p.r_mm <= shape.r_max) {
      lines.back().radii_inside.push_back(p.r_mm);
      ++inside;
    }
    scan.push_back(p);
  }
  if (inside < kMinPointsInside) {
    throw InputError(path + ": " + std::to_string(inside) + " points inside the profile's radii " +
                     Mm(shape.r_min) + ".." + Mm(shape.r_max) + " mm: expected at least " +
                     std::to_string(kMinPointsInside));
  }
  for (const ScanLine& line : lines) CheckGaps(path, line, shape, max_gap);
  return scan;
}

}  // namespace omni::io
