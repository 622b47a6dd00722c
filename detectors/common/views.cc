#include "detectors/common/views.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "detectors/common/option_check.h"
#include "model/ideal_analysis.h"
#include "model/model_derived.h"
#include "model/rig_frames.h"

namespace omni::detectors {
namespace {

double Deg(double deg) { return deg * M_PI / 180.0; }

// The outer ring's tangential resolution (pixels per radian of azimuth) at its middle elevation:
// the radius of that circle in the image, from the ideal model [m1].
double OuterRingPixelsPerRad(const IdealModel& ideal, const FieldOfView& fov) {
  const double elevation = 0.5 * (fov.theta1_min + fov.theta1_max);
  const Eigen::Vector3d point =
      ideal.Focus1() + 1000.0 * Eigen::Vector3d(std::cos(elevation), 0, std::sin(elevation));
  Eigen::Vector2d pixel;
  if (!ideal.Project(point, Mirror::kOne, &pixel)) return ideal.cam.fx * 0.2;
  return std::hypot(pixel.x() - ideal.cam.cx, (pixel.y() - ideal.cam.cy) * ideal.cam.fx / ideal.cam.fy);
}

// One optical path's views: where they look from and the elevations (rad) of the ring's
// field of view, before the margin and the cap.
struct PathField {
  Mirror mirror = Mirror::kOne;
  Eigen::Vector3d viewpoint_in_cam = Eigen::Vector3d::Zero();
  double elevation_lo = 0, elevation_hi = 0;
};

// Unit direction from `viewpoint` to the point of `ray` at `distance` from it (the view's
// convention, RingView::RawToView); nullopt where the ray never gets that far from it.
std::optional<Eigen::Vector3d> DirectionAtDistance(const Ray& ray, const Eigen::Vector3d& viewpoint,
                                                   double distance) {
  const Eigen::Vector3d o = ray.origin - viewpoint;
  const double b = ray.direction.dot(o), c = o.squaredNorm() - distance * distance;
  if (b * b - c < 0) return std::nullopt;
  return (o + (-b + std::sqrt(b * b - c)) * ray.direction).normalized();
}

// The folded rig's two rings: viewpoints at the mirrors' outer foci [m1], [m2], elevations
// from the design's field of view [theta1_limits] (the ideal rig's: the views only find targets).
std::vector<PathField> FoldedFields(const RigParams& rig, const FieldOfView& fov) {
  PathField one{Mirror::kOne, Focus1InCam(rig.mirror1_pose.data(), rig.mirror1_shape.data()),
                std::min(fov.theta1_min, fov.theta1_max), std::max(fov.theta1_min, fov.theta1_max)};
  PathField two{Mirror::kTwo,
                Focus2InCam(rig.mirror2_pose.data(), rig.mirror2_shape.data(), rig.d),
                std::min(fov.theta2_min, fov.theta2_max), std::max(fov.theta2_min, fov.theta2_max)};
  return {one, two};
}

// A single mirror's one ring, seen from its near focus (model_derived.h; a sphere's centre):
// the elevations of the world rays the model itself traces back from the images of the used
// annulus's edges (r_cam and r_sys, a hair inside) at 16 azimuths, so any conic, lens and
// misalignment gets its own band. Where no edge pixel traces (a model that sees nothing), the
// directions from the focus to the edges' points on the mirror.
PathField SingleField(const RigModel& model, double distance) {
  const RigParams& rig = model.params();
  const Mirror1Path<double>& path = model.path1();
  PathField field{Mirror::kOne, ComputeModelDerived(rig).focus1_in_cam, 0, 0};
  const double hair = 1e-3 * (rig.r_sys - rig.r_cam);
  double lo = 1e9, hi = -1e9, lo_mirror = 1e9, hi_mirror = -1e9;
  for (int k = 0; k < 16; ++k) {
    const double t = 2 * M_PI * k / 16;
    for (const double r : {rig.r_cam + hair, rig.r_sys - hair}) {
      const double x = r * std::cos(t), y = r * std::sin(t);
      const Eigen::Vector3d on_mirror = path.cam_from_mirror * Eigen::Vector3d(x, y, path.sheet.Z(x, y));
      const double e_mirror = std::asin((on_mirror - field.viewpoint_in_cam).normalized().z());
      lo_mirror = std::min(lo_mirror, e_mirror);
      hi_mirror = std::max(hi_mirror, e_mirror);
      const auto ray = model.Unproject(PixelOfPointInCam(path.cam, path.dist, on_mirror, rig.lens));
      if (!ray) continue;
      const auto dir = DirectionAtDistance(ray->ray, field.viewpoint_in_cam, distance);
      if (!dir) continue;
      lo = std::min(lo, std::asin(dir->z()));
      hi = std::max(hi, std::asin(dir->z()));
    }
  }
  field.elevation_lo = lo <= hi ? lo : lo_mirror;
  field.elevation_hi = lo <= hi ? hi : hi_mirror;
  return field;
}

// A single mirror's tangential resolution (raw px per radian of azimuth) at the middle of its
// elevations: the outer ring's rule (OuterRingPixelsPerRad), measured through the model (the
// median over 8 azimuths: a tilted mirror's ring is wider on one side).
double SinglePixelsPerRad(const RigModel& model, const PathField& field, double distance) {
  const double e = 0.5 * (field.elevation_lo + field.elevation_hi), step = 1e-3;
  auto pixel_at = [&](double azimuth) {
    return model.Project(field.viewpoint_in_cam +
                             distance * Eigen::Vector3d(std::cos(e) * std::cos(azimuth),
                                                        std::cos(e) * std::sin(azimuth), std::sin(e)),
                         Mirror::kOne);
  };
  std::vector<double> measured;
  for (int k = 0; k < 8; ++k) {
    const double azimuth = 2 * M_PI * k / 8;
    const auto a = pixel_at(azimuth), b = pixel_at(azimuth + step);
    if (a && b) measured.push_back((*b - *a).norm() / step);
  }
  if (measured.empty()) return 0.25 * std::min(model.params().image_width, model.params().image_height);
  std::nth_element(measured.begin(), measured.begin() + measured.size() / 2, measured.end());
  return measured[measured.size() / 2];
}

RingView MakeView(const RigModel& model, const PathField& field, double azimuth, double elevation_lo,
                  double elevation_hi, double pixels_per_rad, const ViewOptions& options) {
  RingView v;
  v.mirror = field.mirror;
  v.azimuth = azimuth;
  v.sectors = options.sectors;
  v.elevation = 0.5 * (elevation_lo + elevation_hi);
  v.distance_mm = options.distance_mm;
  const RigParams& rig = model.params();
  v.viewpoint_in_cam = field.viewpoint_in_cam;
  const Eigen::Vector3d forward(std::cos(v.elevation) * std::cos(azimuth),
                                std::cos(v.elevation) * std::sin(azimuth), std::sin(v.elevation));
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  v.cam_from_view.col(0) = right;
  v.cam_from_view.col(1) = down;
  v.cam_from_view.col(2) = forward;
  v.f = pixels_per_rad;
  const double half_h = std::tan(0.5 * Deg(options.horizontal_fov_deg));
  const double half_v = std::tan(0.5 * (elevation_hi - elevation_lo));
  v.width = 2 * static_cast<int>(std::ceil(v.f * half_h));
  v.height = 2 * static_cast<int>(std::ceil(v.f * half_v));
  v.cx = 0.5 * (v.width - 1);
  v.cy = 0.5 * (v.height - 1);

  // Exact projections on a grid of nodes, bilinear inside cells whose four nodes are valid,
  // exact per pixel in the others (ring boundaries).
  const int step = std::max(1, options.grid_step);
  const int nx = (v.width - 1) / step + 2, ny = (v.height - 1) / step + 2;
  std::vector<std::optional<Eigen::Vector2d>> nodes(nx * ny);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      nodes[j * nx + i] = v.ViewToRawExact(model, Eigen::Vector2d(i * step, j * step));
    }
  }
  v.map_x.create(v.height, v.width, CV_32F);
  v.map_y.create(v.height, v.width, CV_32F);
  for (int y = 0; y < v.height; ++y) {
    const int j = y / step;
    const double ty = static_cast<double>(y - j * step) / step;
    float* mx = v.map_x.ptr<float>(y);
    float* my = v.map_y.ptr<float>(y);
    for (int x = 0; x < v.width; ++x) {
      const int i = x / step;
      const double tx = static_cast<double>(x - i * step) / step;
      const auto& n00 = nodes[j * nx + i];
      const auto& n10 = nodes[j * nx + i + 1];
      const auto& n01 = nodes[(j + 1) * nx + i];
      const auto& n11 = nodes[(j + 1) * nx + i + 1];
      std::optional<Eigen::Vector2d> raw;
      if (n00 && n10 && n01 && n11) {
        raw = (1 - ty) * ((1 - tx) * *n00 + tx * *n10) + ty * ((1 - tx) * *n01 + tx * *n11);
      } else if (n00 || n10 || n01 || n11) {
        raw = v.ViewToRawExact(model, Eigen::Vector2d(x, y));
      }
      const bool inside = raw && raw->x() >= 0 && raw->y() >= 0 &&
                          raw->x() <= rig.image_width - 1 && raw->y() <= rig.image_height - 1;
      mx[x] = inside ? static_cast<float>(raw->x()) : -1.f;
      my[x] = inside ? static_cast<float>(raw->y()) : -1.f;
    }
  }
  cv::convertMaps(v.map_x, v.map_y, v.map_fixed, v.map_interp, CV_16SC2);
  v.valid_for_blur = BlurValidMask(v.map_x);
  v.valid_for_saddles = SaddleValidMask(v.map_x);
  return v;
}

}  // namespace

Eigen::Vector3d RingView::RayInCam(const Eigen::Vector2d& view_pixel) const {
  return (cam_from_view * Eigen::Vector3d((view_pixel.x() - cx) / f, (view_pixel.y() - cy) / f, 1))
      .normalized();
}

std::optional<Eigen::Vector2d> RingView::ViewPixelOfDirection(const Eigen::Vector3d& dir_in_cam) const {
  const Eigen::Vector3d d = cam_from_view.transpose() * dir_in_cam;
  if (!(d.z() > 1e-9)) return std::nullopt;
  return Eigen::Vector2d(cx + f * d.x() / d.z(), cy + f * d.y() / d.z());
}

std::optional<Eigen::Vector2d> RingView::ViewToRaw(const Eigen::Vector2d& view_pixel) const {
  const double x = view_pixel.x(), y = view_pixel.y();
  if (!(x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1)) return std::nullopt;
  const int i = std::min(static_cast<int>(x), width - 2), j = std::min(static_cast<int>(y), height - 2);
  const double tx = x - i, ty = y - j;
  Eigen::Vector2d out = Eigen::Vector2d::Zero();
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const float u = map_x.at<float>(j + dj, i + di), w = map_y.at<float>(j + dj, i + di);
      if (u < 0) return std::nullopt;
      out += (di ? tx : 1 - tx) * (dj ? ty : 1 - ty) * Eigen::Vector2d(u, w);
    }
  }
  return out;
}

std::optional<Eigen::Vector2d> RingView::ViewToRawExact(const RigModel& model,
                                                        const Eigen::Vector2d& view_pixel) const {
  return model.Project(viewpoint_in_cam + distance_mm * RayInCam(view_pixel), mirror);
}

std::optional<Eigen::Vector2d> RingView::RawToView(const RigModel& model,
                                                   const Eigen::Vector2d& raw_pixel) const {
  const auto ray = model.Unproject(raw_pixel);
  if (!ray || ray->mirror != mirror) return std::nullopt;
  const auto direction = DirectionAtDistance(ray->ray, viewpoint_in_cam, distance_mm);
  if (!direction) return std::nullopt;
  auto pixel = ViewPixelOfDirection(*direction);
  if (!pixel || pixel->x() < 0 || pixel->y() < 0 || pixel->x() > width - 1 || pixel->y() > height - 1) {
    return std::nullopt;
  }
  return pixel;
}

double RingView::RawBlurAt(const Eigen::Vector2d& view_pixel) const {
  if (!blur_sigma) return 0;
  const auto c = ViewToRaw(view_pixel);
  const auto x = ViewToRaw(view_pixel + Eigen::Vector2d(2, 0));
  const auto y = ViewToRaw(view_pixel + Eigen::Vector2d(0, 2));
  if (!c || !x || !y) return 0;
  const double det = std::abs((*x - *c).x() * (*y - *c).y() - (*x - *c).y() * (*y - *c).x()) / 4;
  return *blur_sigma * std::sqrt(det);
}

std::string ViewOptions::Check() const {
  if (sectors < 1) return OptionError("sectors", "at least 1 view per ring", sectors);
  if (!(horizontal_fov_deg > 0 && horizontal_fov_deg < 180)) {
    return OptionError("horizontal_fov_deg", "an angle in (0, 180) degrees", horizontal_fov_deg);
  }
  if (!(max_vertical_fov_deg > 0 && max_vertical_fov_deg < 180)) {
    return OptionError("max_vertical_fov_deg", "an angle in (0, 180) degrees", max_vertical_fov_deg);
  }
  if (!(elevation_margin_deg >= 0)) {
    return OptionError("elevation_margin_deg", "an angle >= 0 degrees", elevation_margin_deg);
  }
  if (!(pixels_per_rad >= 0)) {
    return OptionError("pixels_per_rad", "a resolution > 0 px/rad (0: the outer ring's)", pixels_per_rad);
  }
  if (!(distance_mm > 0)) return OptionError("distance_mm", "a distance > 0 mm", distance_mm);
  if (grid_step < 1) return OptionError("grid_step", "at least 1 view px", grid_step);
  return "";
}

std::vector<RingView> MakeRingViews(const RigModel& model, const ViewOptions& options) {
  if (const std::string error = options.Check(); !error.empty()) throw std::invalid_argument(error);
  const RigParams& rig = model.params();
  std::vector<PathField> fields;
  double pixels_per_rad = options.pixels_per_rad;
  if (rig.Single()) {
    fields.push_back(SingleField(model, options.distance_mm));
    if (!(pixels_per_rad > 0)) pixels_per_rad = SinglePixelsPerRad(model, fields[0], options.distance_mm);
  } else {
    const IdealModel ideal = rig.Ideal();
    const FieldOfView fov = ComputeFieldOfView(rig.Design(), ideal.r_ref, ideal.r_cam);
    fields = FoldedFields(rig, fov);
    if (!(pixels_per_rad > 0)) pixels_per_rad = OuterRingPixelsPerRad(ideal, fov);
  }
  const double margin = Deg(options.elevation_margin_deg);
  std::vector<RingView> views;
  for (const PathField& field : fields) {
    double lo = field.elevation_lo - margin;
    double hi = field.elevation_hi + margin;
    const double cap = Deg(options.max_vertical_fov_deg);
    // Where the ring's field fits within the cap only the margins beyond it are cut (the part
    // nearest the horizon is kept, where targets are); a field taller than the cap (a wide single
    // mirror: a paraboloid's ring spans 70-110 deg) is covered whole by taller views, since a
    // board anywhere in it must fit one (cutting it lost the boards nearest the mirror's centre).
    const double field_height = field.elevation_hi - field.elevation_lo;
    if (hi - lo > cap && field_height <= cap) {
      const double centre = std::clamp(0.0, lo + 0.5 * cap, hi - 0.5 * cap);
      lo = centre - 0.5 * cap;
      hi = centre + 0.5 * cap;
    }
    // A pinhole view's height grows as the tangent of its half-angle: at most 150 degrees.
    constexpr double kTallest = 150 * M_PI / 180;
    if (hi - lo > kTallest) {
      const double centre = 0.5 * (field.elevation_lo + field.elevation_hi);
      lo = centre - 0.5 * kTallest;
      hi = centre + 0.5 * kTallest;
    }
    for (int k = 0; k < options.sectors; ++k) {
      views.push_back(MakeView(model, field, 2 * M_PI * k / options.sectors, lo, hi,
                               pixels_per_rad, options));
    }
  }
  return views;
}

cv::Mat ToGrey(const cv::Mat& raw) {
  cv::Mat grey;
  if (raw.channels() == 3) {
    cv::cvtColor(raw, grey, cv::COLOR_BGR2GRAY);
  } else if (raw.channels() == 4) {
    cv::cvtColor(raw, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = raw;
  }
  if (grey.depth() != CV_8U) {
    cv::Mat g8;
    grey.convertTo(g8, CV_8U, grey.depth() == CV_16U ? 1.0 / 257.0 : 1.0);
    grey = g8;
  }
  return grey;
}

namespace {

// The blur measure's local-contrast window (view px): +-6 px, 3 sigma of the widest blur it is
// calibrated for (2 px; views.h), so that the whole blurred step lies inside it. A blur in view
// pixels is the camera's in raw pixels (the views have the outer ring's raw resolution), the
// same at any image size: the window is a multiple of the blur, not of an angle.
constexpr int kBlurWindowHalf = 6;
// Grey levels (0..255) across that window for a pixel to be measured: an edge, not noise.
constexpr int kBlurMinContrast = 60;

cv::Mat BlurWindow() {
  return cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kBlurWindowHalf + 1, 2 * kBlurWindowHalf + 1));
}

}  // namespace

cv::Mat BlurValidMask(const cv::Mat& map_x) {
  cv::Mat valid;  // the blur window must not reach the view's black outside
  cv::erode(map_x >= 0, valid, BlurWindow());
  return valid;
}

cv::Mat SaddleValidMask(const cv::Mat& map_x) {
  cv::Mat valid;  // not next to the view's invalid area (its edge is a strong false feature)
  cv::erode(map_x >= 0, valid, cv::Mat(), cv::Point(-1, -1), 3);
  return valid;
}

std::optional<double> ViewBlurSigma(const cv::Mat& view_image, const cv::Mat& map_x) {
  return BlurWhereValid(view_image, BlurValidMask(map_x));
}

std::optional<double> BlurWhereValid(const cv::Mat& view_image, const cv::Mat& valid) {
  CV_Assert(view_image.type() == CV_8U);
  cv::Mat gx, gy, hi, lo;
  cv::Sobel(view_image, gx, CV_16S, 1, 0, 3);
  cv::Sobel(view_image, gy, CV_16S, 0, 1, 3);
  const cv::Mat box = BlurWindow();
  cv::dilate(view_image, hi, box);
  cv::erode(view_image, lo, box);
  // Every second pixel of every second row: the percentile does not need them all.
  std::vector<float> ratio;
  for (int y = 0; y < view_image.rows; y += 2) {
    const uchar *h = hi.ptr<uchar>(y), *l = lo.ptr<uchar>(y), *ok = valid.ptr<uchar>(y);
    const int16_t *dx = gx.ptr<int16_t>(y), *dy = gy.ptr<int16_t>(y);
    for (int x = 0; x < view_image.cols; x += 2) {
      const int contrast = h[x] - l[x];
      if (!ok[x] || contrast < kBlurMinContrast) continue;
      // The 3x3 Sobel's gain is 8.
      ratio.push_back(std::hypot(static_cast<float>(dx[x]), static_cast<float>(dy[x])) /
                      (8.0f * static_cast<float>(contrast)));
    }
  }
  if (ratio.size() < 200) return std::nullopt;
  const auto k = ratio.begin() + static_cast<long>(0.98 * (ratio.size() - 1));
  std::nth_element(ratio.begin(), k, ratio.end());
  // A step of contrast C blurred by s has a peak gradient C / (sqrt(2 pi) s).
  const double measured = 1.0 / (std::sqrt(2 * M_PI) * *k);
  return std::sqrt(std::max(0.0, measured * measured - 0.5));
}

void RenderViews(const cv::Mat& raw, std::vector<RingView>* views) {
  const cv::Mat grey = ToGrey(raw);
  for (RingView& v : *views) {
    cv::remap(grey, v.image, v.map_fixed, v.map_interp, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    v.saddle_cache = {};
  }
  // One blur per ring (its views agree within ~5%): the median over its views that show enough
  // edges (every view: a scene may show edges in a few views only).
  for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
    std::vector<double> measured;
    for (const RingView& v : *views) {
      if (v.mirror != mirror) continue;
      const cv::Mat valid =
          v.valid_for_blur.size() == v.map_x.size() ? v.valid_for_blur : BlurValidMask(v.map_x);
      if (const auto b = BlurWhereValid(v.image, valid)) measured.push_back(*b);
    }
    std::optional<double> ring_blur;
    if (!measured.empty()) {
      std::nth_element(measured.begin(), measured.begin() + measured.size() / 2, measured.end());
      ring_blur = measured[measured.size() / 2];
    }
    for (RingView& v : *views) {
      if (v.mirror == mirror) v.blur_sigma = ring_blur;
    }
  }
}

}  // namespace omni::detectors
