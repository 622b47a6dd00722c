#include "model/stereo/dense_stereo.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <ceres/jet.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "model/ideal_analysis.h"
#include "model/triangulation.h"

namespace omni::stereo {
namespace {

using Jet12 = ceres::Jet<double, 12>;

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// Catmull-Rom cubic through column samples p[-1..2] at t in [0, 1), and its derivative.
inline void CatmullRom(const float* p0, size_t step, double t, double* value, double* slope) {
  const double pm = p0[-static_cast<std::ptrdiff_t>(step)], a = p0[0], b = p0[step],
               pp = p0[2 * step];
  const double c1 = 0.5 * (b - pm), c2 = pm - 2.5 * a + 2 * b - 0.5 * pp,
               c3 = 0.5 * (pp - pm) + 1.5 * (a - b);
  *value = a + t * (c1 + t * (c2 + t * c3));
  *slope = c1 + t * (2 * c2 + t * 3 * c3);
}

}  // namespace

bool RefineDisparity(const cv::Mat& xi1, const cv::Mat& xi2, int u, int v, double d0,
                     int half_width, int half_height, double* d) {
  const int w = xi1.cols;
  const size_t step = xi2.step1();
  double disparity = d0;
  for (int iteration = 0; iteration < 4; ++iteration) {
    // Normal equations of r = I1 - I2(v' - d) - b in (delta d, b): dr/dd = I2'(v' - d), dr/db = -1.
    double h11 = 0, h12 = 0, h22 = 0, g1 = 0, g2 = 0;
    const double y = v - disparity;
    const int y0 = static_cast<int>(std::floor(y));
    const double t = y - y0;
    if (y0 - half_height - 1 < 0 || y0 + half_height + 2 >= xi2.rows ||
        v - half_height < 0 || v + half_height >= xi1.rows) {
      return false;
    }
    for (int du = -half_width; du <= half_width; ++du) {
      const int c = (u + du + w) % w;
      for (int dv = -half_height; dv <= half_height; ++dv) {
        double i2, slope;
        CatmullRom(xi2.ptr<float>(y0 + dv) + c, step, t, &i2, &slope);
        const double r = xi1.at<float>(v + dv, c) - i2;
        h11 += slope * slope;
        h12 -= slope;
        h22 += 1;
        g1 += slope * r;
        g2 -= r;
      }
    }
    const double det = h11 * h22 - h12 * h12;
    if (!(det > 1e-6 * h22 * h11) || h11 < 1e-3 * h22) return false;  // flat window
    // Gauss-Newton step (J^T J) x = -J^T r, J = (slope, -1); the offset b is re-solved from 0 at
    // every step (the problem is linear in it), only the disparity step is kept.
    const double delta = -(h22 * g1 - h12 * g2) / det;
    disparity += delta;
    if (std::abs(disparity - d0) > 1.0) return false;
    if (std::abs(delta) < 1e-3) break;
  }
  *d = disparity;
  return true;
}

// A ring's exact ray at each panorama pixel of rows [row_begin, row_end), and its Jacobian
// w.r.t. the raw pixel: 6 x 2 (origin then direction, by u and v).
struct DenseStereo::RayTable {
  int width = 0, row_begin = 0, row_end = 0;
  std::vector<double> ray;             // 6 per pixel: origin, direction
  std::vector<float> jacobian;         // 12 per pixel, row-major 6 x 2
  std::vector<std::uint8_t> valid;

  size_t Index(int u, int v) const { return static_cast<size_t>(v - row_begin) * width + u; }

  void Build(const RigModel& model, Mirror mirror, const cv::Mat& map_x, const cv::Mat& map_y,
             int begin, int end) {
    width = map_x.cols;
    row_begin = begin;
    row_end = end;
    const size_t n = static_cast<size_t>(end - begin) * width;
    ray.assign(6 * n, 0.0);
    jacobian.assign(12 * n, 0.f);
    valid.assign(n, 0);
    constexpr double h = 1e-3;  // px; see triangulation.h on the step
    auto unproject = [&](const Eigen::Vector2d& px, Eigen::Matrix<double, 6, 1>* out) {
      const auto r = model.Unproject(px);
      if (!r || r->mirror != mirror) return false;
      out->head<3>() = r->ray.origin;
      out->tail<3>() = r->ray.direction;
      return true;
    };
    cv::parallel_for_(cv::Range(begin, end), [&](const cv::Range& rows) {
      for (int v = rows.start; v < rows.end; ++v) {
        for (int u = 0; u < width; ++u) {
          const Eigen::Vector2d px(map_x.at<float>(v, u), map_y.at<float>(v, u));
          if (px.x() < 0) continue;
          Eigen::Matrix<double, 6, 1> centre, plus, minus;
          if (!unproject(px, &centre)) continue;
          Eigen::Matrix<double, 6, 2> J;
          bool ok = true;
          for (int k = 0; k < 2 && ok; ++k) {
            Eigen::Vector2d step = Eigen::Vector2d::Zero();
            step[k] = h;
            const bool p = unproject(px + step, &plus), m = unproject(px - step, &minus);
            if (p && m) J.col(k) = (plus - minus) / (2 * h);
            else if (p) J.col(k) = (plus - centre) / h;
            else if (m) J.col(k) = (centre - minus) / h;
            else ok = false;
          }
          if (!ok) continue;
          const size_t i = Index(u, v);
          for (int r = 0; r < 6; ++r) {
            ray[6 * i + r] = centre[r];
            for (int c = 0; c < 2; ++c) jacobian[12 * i + 2 * r + c] = static_cast<float>(J(r, c));
          }
          valid[i] = 1;
        }
      }
    });
  }

  // Ray and Jacobian at column u and (sub-pixel) row v, linear between rows.
  bool At(int u, double v, Eigen::Matrix<double, 6, 1>* r, Eigen::Matrix<double, 6, 2>* J) const {
    const int v0 = static_cast<int>(std::floor(v));
    const double t = v - v0;
    const int v1 = t > 0 ? v0 + 1 : v0;
    if (v0 < row_begin || v1 >= row_end) return false;
    const size_t i0 = Index(u, v0), i1 = Index(u, v1);
    if (!valid[i0] || !valid[i1]) return false;
    for (int k = 0; k < 6; ++k) {
      (*r)[k] = (1 - t) * ray[6 * i0 + k] + t * ray[6 * i1 + k];
      for (int c = 0; c < 2; ++c) {
        (*J)(k, c) = (1 - t) * jacobian[12 * i0 + 2 * k + c] + t * jacobian[12 * i1 + 2 * k + c];
      }
    }
    return true;
  }
};

DenseStereo::~DenseStereo() = default;

DenseStereo::DenseStereo(const RigModel& model, const PanoramaOptions& panorama_options,
                         const DepthOptions& depth_options)
    : model_(model), options_(depth_options) {
  if (options_.num_disparities < 16 || options_.num_disparities % 16 != 0) {
    throw std::invalid_argument("num_disparities: expected a positive multiple of 16");
  }
  if (options_.block_size < 1 || options_.block_size % 2 == 0) {
    throw std::invalid_argument("block_size: expected an odd number >= 1");
  }
  luts_ = BuildPanoramaLuts(model_, panorama_options);
  const PanoramaGeometry& g = luts_.geometry;
  // The band of Xi_1 rows inside the stereo ROI [common_FOV_limit_angles].
  const RigParams& rig = model_.params();
  const FieldOfView fov = ComputeFieldOfView(rig.Design(), rig.r_ref, rig.r_cam);
  band_begin_ = std::clamp(static_cast<int>(std::ceil(g.RowOfElevation(fov.theta_sroi_max))), 0,
                           g.height);
  band_end_ = std::clamp(static_cast<int>(std::floor(g.RowOfElevation(fov.theta_sroi_min))) + 1,
                         band_begin_, g.height);
  crop_begin_ = std::max(0, band_begin_ - options_.num_disparities);
  rays_[0] = std::make_unique<RayTable>();
  rays_[1] = std::make_unique<RayTable>();
  rays_[0]->Build(model_, Mirror::kOne, luts_.map_x[0], luts_.map_y[0], band_begin_, band_end_);
  rays_[1]->Build(model_, Mirror::kTwo, luts_.map_x[1], luts_.map_y[1], crop_begin_, band_end_);
}

void DenseStereo::MatchBand(const cv::Mat& image, DepthFrame* frame, cv::Mat grey[2],
                            cv::Mat* disparity16) const {
  const RigParams& rig = model_.params();
  if (image.cols != rig.image_width || image.rows != rig.image_height) {
    throw std::invalid_argument("image size " + std::to_string(image.cols) + "x" +
                                std::to_string(image.rows) + ": expected the model's " +
                                std::to_string(rig.image_width) + "x" +
                                std::to_string(rig.image_height));
  }
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    throw std::invalid_argument("image: expected 8-bit grey or BGR");
  }
  auto t0 = std::chrono::steady_clock::now();
  Unwarp(image, luts_, Mirror::kOne, &frame->panorama[0]);
  Unwarp(image, luts_, Mirror::kTwo, &frame->panorama[1]);
  frame->seconds_remap = Seconds(t0);

  // SGBM on the transposed band (see the header on the disparity convention).
  t0 = std::chrono::steady_clock::now();
  const cv::Range rows(crop_begin_, band_end_);
  cv::Mat left, right;
  for (int i = 0; i < 2; ++i) {
    const cv::Mat band = frame->panorama[i].rowRange(rows);
    if (band.channels() == 3) cv::cvtColor(band, grey[i], cv::COLOR_BGR2GRAY);
    else grey[i] = band;
  }
  cv::transpose(grey[0], left);
  cv::transpose(grey[1], right);
  const int cn = 1, bs = options_.block_size;
  auto sgbm = cv::StereoSGBM::create(0, options_.num_disparities, bs, 8 * cn * bs * bs,
                                     32 * cn * bs * bs, options_.disp12_max_diff, 0,
                                     options_.uniqueness_ratio, options_.speckle_window,
                                     options_.speckle_range,
                                     options_.three_way ? cv::StereoSGBM::MODE_SGBM_3WAY
                                                        : cv::StereoSGBM::MODE_SGBM);
  sgbm->compute(left, right, *disparity16);  // CV_16S, x16, transposed
  frame->seconds_sgbm = Seconds(t0);
  frame->band_row_begin = band_begin_;
  frame->band_row_end = band_end_;
}

DepthFrame DenseStereo::Disparity(const cv::Mat& image) const {
  DepthFrame frame;
  cv::Mat grey[2], disparity16;
  MatchBand(image, &frame, grey, &disparity16);
  const PanoramaGeometry& g = luts_.geometry;
  frame.disparity = cv::Mat(g.height, g.width, CV_32FC1,
                            cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int u = 0; u < g.width; ++u) {
    const std::int16_t* d_row = disparity16.ptr<std::int16_t>(u);  // transposed: row = column u
    for (int v = band_begin_; v < band_end_; ++v) {
      const int x = v - crop_begin_;
      if (d_row[x] > 0) frame.disparity.at<float>(v, u) = static_cast<float>(d_row[x] / 16.0);
    }
  }
  return frame;
}

DepthFrame DenseStereo::Compute(const cv::Mat& image) const {
  DepthFrame frame;
  cv::Mat grey[2], disparity16;
  MatchBand(image, &frame, grey, &disparity16);
  // Float panoramas of the band for the sub-pixel refinement (rows relative to crop_begin_).
  cv::Mat band_f[2];
  if (options_.refine_subpixel) {
    for (int i = 0; i < 2; ++i) grey[i].convertTo(band_f[i], CV_32F);
  }

  // Triangulate every valid match of the band.
  auto t0 = std::chrono::steady_clock::now();
  const PanoramaGeometry& g = luts_.geometry;
  frame.disparity = cv::Mat(g.height, g.width, CV_32FC1,
                            cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const double sigma2 = options_.sigma_px * options_.sigma_px;
  const cv::Mat& colour = frame.panorama[0];
  std::vector<std::vector<DensePoint>> per_column(g.width);
  cv::parallel_for_(cv::Range(0, g.width), [&](const cv::Range& cols) {
    for (int u = cols.start; u < cols.end; ++u) {
      const std::int16_t* d_row = disparity16.ptr<std::int16_t>(u);  // transposed: row = column u
      for (int v = band_begin_; v < band_end_; ++v) {
        const int x = v - crop_begin_;
        if (d_row[x] <= 0) continue;  // invalid (negative) or zero disparity
        double d = d_row[x] / 16.0;
        if (options_.refine_subpixel) {
          double refined;
          if (RefineDisparity(band_f[0], band_f[1], u, x, d, options_.refine_half_width,
                              options_.refine_half_height, &refined)) {
            d = refined;
          }
        }
        if (d < options_.min_disparity_px) continue;
        Eigen::Matrix<double, 6, 1> r1, r2;
        Eigen::Matrix<double, 6, 2> J1, J2;
        if (!rays_[0]->At(u, v, &r1, &J1) || !rays_[1]->At(u, v - d, &r2, &J2)) continue;
        // [midpoint_on_common_perpendicular] with Jets over (o1, d1, o2, d2).
        Vec3<Jet12> o1, d1, o2, d2, mid;
        for (int k = 0; k < 3; ++k) {
          o1[k] = Jet12(r1[k], k);
          d1[k] = Jet12(r1[3 + k], 3 + k);
          o2[k] = Jet12(r2[k], 6 + k);
          d2[k] = Jet12(r2[3 + k], 9 + k);
        }
        Jet12 l1, l2;
        if (!MidpointOnCommonPerpendicular(o1, d1, o2, d2, &mid, &l1, &l2)) continue;
        if (!(l1.a > 0) || !(l2.a > 0)) continue;
        Eigen::Matrix<double, 3, 12> dmid_drays;
        for (int k = 0; k < 3; ++k) dmid_drays.row(k) = mid[k].v.transpose();
        // A = d point / d (u1, v1, u2, v2) = d point / d rays * d rays / d pixels.
        const Eigen::Matrix<double, 3, 2> A1 = dmid_drays.leftCols<6>() * J1;
        const Eigen::Matrix<double, 3, 2> A2 = dmid_drays.rightCols<6>() * J2;
        const Eigen::Matrix3d cov =
            sigma2 * (A1 * A1.transpose() + A2 * A2.transpose());  // [uncertainty_propagation]
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
        eigen.computeDirect(cov, Eigen::EigenvaluesOnly);  // closed form: fast for 3x3
        const double lambda_max = eigen.eigenvalues()[2];
        const double sigma = std::sqrt(std::max(0.0, lambda_max));
        if (options_.max_sigma_mm > 0 && sigma > options_.max_sigma_mm) continue;
        DensePoint p;
        p.point_in_cam = Eigen::Vector3f(static_cast<float>(mid[0].a), static_cast<float>(mid[1].a),
                                          static_cast<float>(mid[2].a));
        p.sigma_mm = static_cast<float>(sigma);
        if (colour.channels() == 3) {
          const cv::Vec3b c = colour.at<cv::Vec3b>(v, u);
          p.bgr[0] = c[0], p.bgr[1] = c[1], p.bgr[2] = c[2];
        } else {
          p.bgr[0] = p.bgr[1] = p.bgr[2] = colour.at<std::uint8_t>(v, u);
        }
        p.u = static_cast<std::uint16_t>(u);
        p.v = static_cast<std::uint16_t>(v);
        p.disparity = static_cast<float>(d);
        frame.disparity.at<float>(v, u) = static_cast<float>(d);
        per_column[u].push_back(p);
      }
    }
  });
  for (auto& column : per_column) {
    frame.points.insert(frame.points.end(), column.begin(), column.end());
  }
  frame.seconds_triangulation = Seconds(t0);
  return frame;
}

}  // namespace omni::stereo
