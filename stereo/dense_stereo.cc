#include "stereo/dense_stereo.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "model/model_derived.h"

namespace omni::stereo {
namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

DenseStereo::~DenseStereo() = default;

std::string DepthOptions::Check() const {
  if (num_disparities < 16 || num_disparities % 16 != 0 || num_disparities > 1024) {
    return "num_disparities: expected a multiple of 16 in 16..1024, got " +
           std::to_string(num_disparities);
  }
  if (block_size < 1 || block_size % 2 == 0 || block_size > 31) {
    return "block_size: expected an odd number in 1..31, got " + std::to_string(block_size);
  }
  if (!(sigma_px >= 0)) return "sigma_px: expected a number >= 0";
  if (!(max_sigma_mm >= 0)) return "max_sigma_mm: expected a number >= 0";
  if (refine_half_width < 0 || refine_half_width > 50 || refine_half_height < 0 ||
      refine_half_height > 50) {
    return "refine_half_width, refine_half_height: expected 0..50";
  }
  return "";
}

DenseStereo::DenseStereo(const RigModel& model, const PanoramaOptions& panorama_options,
                         const DepthOptions& depth_options)
    : model_(model), options_(depth_options) {
  if (const std::string error = options_.Check(); !error.empty()) {
    throw std::invalid_argument(error);
  }
  if (model_.params().Single()) {
    throw std::invalid_argument("dense stereo: needs two rings, a single-mirror rig has one");
  }
  luts_ = BuildPanoramaLuts(model_, panorama_options);
  const PanoramaGeometry& g = luts_.geometry;
  // The band of Xi_1 rows inside the stereo ROI [common_FOV_limit_angles].
  const RigParams& rig = model_.params();
  const FieldOfView fov = RigFieldOfView(rig);
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
                            cv::Mat transposed[2], cv::Mat* disparity16) const {
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
  const cv::Range rows(crop_begin_, band_end_);  // what SGBM reads
  const cv::Range remapped = options_.full_panoramas ? cv::Range::all() : rows;
  Unwarp(image, luts_, Mirror::kOne, remapped, &frame->panorama[0]);
  Unwarp(image, luts_, Mirror::kTwo, remapped, &frame->panorama[1]);
  frame->seconds_remap = Seconds(t0);

  // SGBM on the transposed band (see the header on the disparity convention).
  t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < 2; ++i) {
    const cv::Mat band = frame->panorama[i].rowRange(rows);
    if (band.channels() == 3) cv::cvtColor(band, grey[i], cv::COLOR_BGR2GRAY);
    else grey[i] = band;
  }
  cv::transpose(grey[0], transposed[0]);
  cv::transpose(grey[1], transposed[1]);
  const int cn = 1, bs = options_.block_size;
  auto sgbm = cv::StereoSGBM::create(0, options_.num_disparities, bs, 8 * cn * bs * bs,
                                     32 * cn * bs * bs, options_.disp12_max_diff, 0,
                                     options_.uniqueness_ratio, options_.speckle_window,
                                     options_.speckle_range,
                                     options_.three_way ? cv::StereoSGBM::MODE_SGBM_3WAY
                                                        : cv::StereoSGBM::MODE_SGBM);
  sgbm->compute(transposed[0], transposed[1], *disparity16);  // CV_16S, x16, transposed
  frame->seconds_sgbm = Seconds(t0);
  frame->band_row_begin = band_begin_;
  frame->band_row_end = band_end_;
}

DepthFrame DenseStereo::Disparity(const cv::Mat& image) const {
  DepthFrame frame;
  cv::Mat grey[2], transposed[2], disparity16;
  MatchBand(image, &frame, grey, transposed, &disparity16);
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
  cv::Mat grey[2], transposed[2], disparity16;
  MatchBand(image, &frame, grey, transposed, &disparity16);

  // Refine and triangulate every valid match of the band.
  auto t0 = std::chrono::steady_clock::now();
  const bool reference = options_.reference_path;
  const int hw = options_.refine_half_width, hh = options_.refine_half_height;
  cv::Mat band_f[2];                         // the reference refinement's float band
  std::unique_ptr<DisparityRefiner> refiner;  // the tabulated one's window sums
  if (options_.refine_subpixel && reference) {
    for (int i = 0; i < 2; ++i) grey[i].convertTo(band_f[i], CV_32F);
  } else if (options_.refine_subpixel) {
    refiner = std::make_unique<DisparityRefiner>(transposed[0], transposed[1], hw, hh);
  }
  const PanoramaGeometry& g = luts_.geometry;
  frame.disparity = cv::Mat(g.height, g.width, CV_32FC1,
                            cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const cv::Mat& colour = frame.panorama[0];
  std::vector<std::vector<DensePoint>> per_column(g.width);
  cv::parallel_for_(cv::Range(0, g.width), [&](const cv::Range& cols) {
    std::vector<int> rows;        // a column's SGBM matches (panorama rows)
    std::vector<double> d_match;  // and their disparities, refined in place
    for (int u = cols.start; u < cols.end; ++u) {
      const std::int16_t* d_row = disparity16.ptr<std::int16_t>(u);  // transposed: row = column u
      per_column[u].reserve(band_end_ - band_begin_);  // one allocation per column
      rows.clear();
      d_match.clear();
      for (int v = band_begin_; v < band_end_; ++v) {
        const std::int16_t d16 = d_row[v - crop_begin_];
        if (d16 <= 0) continue;  // invalid (negative) or zero disparity
        rows.push_back(v);
        d_match.push_back(d16 / 16.0);
      }
      const int n = static_cast<int>(rows.size());
      if (options_.refine_subpixel && reference) {
        for (int i = 0; i < n; ++i) {
          double refined;
          if (RefineDisparity(band_f[0], band_f[1], u, rows[i] - crop_begin_, d_match[i], hw, hh,
                              &refined)) {
            d_match[i] = refined;
          }
        }
      } else if (options_.refine_subpixel) {
        for (int i = 0; i < n; i += 2) {  // two at a time (DisparityRefiner::RefinePair)
          double refined[2];
          bool ok[2];
          if (i + 1 < n) {
            const int x[2] = {rows[i] - crop_begin_, rows[i + 1] - crop_begin_};
            refiner->RefinePair(u, x, &d_match[i], refined, ok);
          } else {
            ok[1] = false;
            ok[0] = refiner->Refine(u, rows[i] - crop_begin_, d_match[i], &refined[0]);
          }
          for (int k = 0; k < 2; ++k) {
            if (ok[k]) d_match[i + k] = refined[k];
          }
        }
      }
      for (int i = 0; i < n; ++i) {
        const int v = rows[i];
        const double d = d_match[i];
        if (d < options_.min_disparity_px) continue;
        MatchPoint m;
        if (!(reference ? TriangulateMatchReference(*rays_[0], *rays_[1], u, v, d,
                                                    options_.sigma_px, &m)
                        : TriangulateMatch(*rays_[0], *rays_[1], u, v, d, options_.sigma_px,
                                           &m))) {
          continue;
        }
        if (options_.max_sigma_mm > 0 && m.sigma_mm > options_.max_sigma_mm) continue;
        DensePoint p;
        p.point_in_cam = m.point_in_cam.cast<float>();
        p.sigma_mm = static_cast<float>(m.sigma_mm);
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
  size_t total = 0;
  for (const auto& column : per_column) total += column.size();
  frame.points.reserve(total);
  for (auto& column : per_column) {
    frame.points.insert(frame.points.end(), column.begin(), column.end());
  }
  frame.seconds_triangulation = Seconds(t0);
  return frame;
}

}  // namespace omni::stereo
