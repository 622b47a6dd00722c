#include "design/sensitivity.h"

#include <cmath>
#include <cstdio>

#include "model/hyperboloid.h"
#include "model/ideal_analysis.h"

namespace omni::design {
namespace {

constexpr double kDeg = 180.0 / M_PI;

double Linspace(double lo, double hi, int n, int i) {
  return n <= 1 ? lo : lo + (hi - lo) * i / (n - 1);
}

// Point (r, z) where the ray from (0, 0, origin_z) with the given direction (in the x-z plane)
// meets the sheet; false if it misses.
bool Hit(const HyperboloidSheet<double>& sheet, double origin_z, double dir_r, double dir_z,
         double* r, double* z) {
  const Eigen::Vector3d origin(0, 0, origin_z), dir(dir_r, 0, dir_z);
  double t = 0;
  if (!sheet.IntersectRay(origin, dir, &t)) return false;
  *r = t * dir_r;
  *z = origin_z + t * dir_z;
  return *r >= 0;
}

std::string Format(const char* fmt, double a) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, a);
  return buf;
}
std::string Num(double v) { return std::isfinite(v) ? Format("%.10g", v) : std::string("nan"); }

}  // namespace

std::vector<RsysVsKRow> RsysVsK(const RsysVsKOptions& o) {
  std::vector<RsysVsKRow> rows;
  for (double alpha : o.alpha1) {
    const double theta_max = o.theta1_min + alpha;
    for (int i = 0; i < o.k_samples; ++i) {
      const double k = Linspace(o.k_min, o.k_max, o.k_samples, i);
      RsysVsKRow row{alpha, k, std::nan(""), std::nan(""), false};
      const auto m1 = HyperboloidSheet<double>::Mirror1(o.c1, k);
      row.valid = Hit(m1, o.c1, std::cos(theta_max), std::sin(theta_max), &row.r_sys, &row.z_max);
      if (!row.valid) row.r_sys = row.z_max = std::nan("");
      rows.push_back(row);
    }
  }
  return rows;
}

std::vector<BaselineVsK1Row> BaselineVsK1(const BaselineVsK1Options& o) {
  std::vector<BaselineVsK1Row> rows;
  for (double alpha : o.alpha) {
    for (int i = 0; i < o.k1_samples; ++i) {
      const double k1 = Linspace(o.k1_min, o.k1_max, o.k1_samples, i);
      BaselineVsK1Row row{alpha, k1, std::nan(""), std::nan(""), std::nan(""),
                          std::nan(""), std::nan(""), std::nan(""), false};
      // Unit-scale mirror 1 (c1 = 1): F1 at z = 1, camera at the origin.
      const auto unit = HyperboloidSheet<double>::Mirror1(1.0, k1);
      double rim_r = 0, rim_z = 0, low_r = 0, low_z = 0;
      if (Hit(unit, 0.0, std::sin(o.alpha_cam / 2), std::cos(o.alpha_cam / 2), &rim_r, &rim_z)) {
        const double theta_max = std::atan2(rim_z - 1.0, rim_r);
        const double theta_min = theta_max - alpha;
        if (Hit(unit, 1.0, std::cos(theta_min), std::sin(theta_min), &low_r, &low_z) &&
            low_z > 0) {
          row.c1 = o.d / (2 * low_z);
          row.r_sys = row.c1 * rim_r;
          row.z_max = row.c1 * rim_z;
          row.theta1_max = theta_max;
          row.theta1_min = theta_min;
          row.baseline = row.c1 + o.c2 - o.d;
          row.valid = true;
        }
      }
      rows.push_back(row);
    }
  }
  return rows;
}

std::vector<ResolutionRow> ResolutionVsElevation(const ResolutionVsElevationOptions& o) {
  std::vector<ResolutionRow> rows;
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    for (double k : mirror == Mirror::kOne ? o.k1 : o.k2) {
      DesignParams theta = o.theta;
      (mirror == Mirror::kOne ? theta.k1 : theta.k2) = k;
      const auto sheet = mirror == Mirror::kOne
                             ? HyperboloidSheet<double>::Mirror1(theta.c1, k)
                             : HyperboloidSheet<double>::Mirror2(theta.c2, k, theta.d);
      const double focus_z = mirror == Mirror::kOne ? theta.c1 : theta.d - theta.c2;
      for (int i = 0; i < o.elevation_samples; ++i) {
        const double elevation = Linspace(o.theta_lo, o.theta_hi, o.elevation_samples, i);
        ResolutionRow row{MirrorIndex(mirror), k, elevation, std::nan(""), std::nan(""),
                          std::nan(""), false};
        double z = 0;
        if (Hit(sheet, focus_z, std::cos(elevation), std::sin(elevation), &row.r, &z)) {
          const Resolution res = SpatialResolution(theta, mirror, row.r, o.f_px);
          row.eta = res.eta;
          row.eta_2d = Resolution2D(res.eta);
          row.valid = std::isfinite(row.eta);
        } else {
          row.r = std::nan("");
        }
        rows.push_back(row);
      }
    }
  }
  return rows;
}

std::string ToCsv(const std::vector<RsysVsKRow>& rows) {
  std::string s = "alpha1_deg,k,r_sys_mm,z_max_mm,valid\n";
  for (const auto& r : rows) {
    s += Num(r.alpha1 * kDeg) + "," + Num(r.k) + "," + Num(r.r_sys) + "," + Num(r.z_max) + "," +
         (r.valid ? "1" : "0") + "\n";
  }
  return s;
}

std::string ToCsv(const std::vector<BaselineVsK1Row>& rows) {
  std::string s =
      "alpha_deg,k1,c1_mm,r_sys_mm,z_max_mm,theta1_max_deg,theta1_min_deg,baseline_mm,valid\n";
  for (const auto& r : rows) {
    s += Num(r.alpha * kDeg) + "," + Num(r.k1) + "," + Num(r.c1) + "," + Num(r.r_sys) + "," +
         Num(r.z_max) + "," + Num(r.theta1_max * kDeg) + "," + Num(r.theta1_min * kDeg) + "," +
         Num(r.baseline) + "," + (r.valid ? "1" : "0") + "\n";
  }
  return s;
}

std::string ToCsv(const std::vector<ResolutionRow>& rows) {
  std::string s = "mirror,k,elevation_deg,r_mm,eta_px2_per_sr,eta_2d,valid\n";
  for (const auto& r : rows) {
    s += std::to_string(r.mirror) + "," + Num(r.k) + "," + Num(r.elevation * kDeg) + "," +
         Num(r.r) + "," + Num(r.eta) + "," + Num(r.eta_2d) + "," + (r.valid ? "1" : "0") + "\n";
  }
  return s;
}

}  // namespace omni::design
