#include "detectors/common/ring_layout.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "model/rig_frames.h"

namespace omni::detectors {
namespace {

constexpr int kBins = 720;  // polar resolution of the boundaries (0.5 degree)

// Pixel of a point in C seen directly by the camera (pinhole + distortion).
Eigen::Vector2d DirectPixel(const RigModel& model, const Eigen::Vector3d& point_in_cam) {
  const Eigen::Vector2d xy = point_in_cam.head<2>() / point_in_cam.z();
  return model.params().Intrinsics().PixelFromNormalized(model.params().Distortion().Distort(xy));
}

// Pixel of a point in C seen in the reflex disc: the camera sees its mirror image.
Eigen::Vector2d ViaReflexPixel(const RigModel& model, const Eigen::Vector3d& point_in_cam) {
  return DirectPixel(model, MirrorPoint(model.path2().reflex_in_cam, point_in_cam));
}

// Resamples image points of a closed curve into r(phi) about `centre`.
RingBoundary ToBoundary(const std::vector<Eigen::Vector2d>& pixels, const Eigen::Vector2d& centre) {
  std::vector<std::pair<double, double>> polar;  // (phi, r)
  polar.reserve(pixels.size());
  for (const auto& p : pixels) {
    const Eigen::Vector2d d = p - centre;
    polar.emplace_back(std::atan2(d.y(), d.x()), d.norm());
  }
  std::sort(polar.begin(), polar.end());
  // Wrap around so that interpolation works across -pi / pi.
  const auto first = polar.front(), last = polar.back();
  polar.insert(polar.begin(), {last.first - 2 * M_PI, last.second});
  polar.push_back({first.first + 2 * M_PI, first.second});
  RingBoundary b;
  b.radius.resize(kBins);
  size_t j = 0;
  for (int k = 0; k < kBins; ++k) {
    const double phi = -M_PI + 2 * M_PI * k / kBins;
    while (j + 2 < polar.size() && polar[j + 1].first < phi) ++j;
    const double t = (phi - polar[j].first) / (polar[j + 1].first - polar[j].first);
    b.radius[k] = polar[j].second + t * (polar[j + 1].second - polar[j].second);
  }
  return b;
}

template <typename PointAt>
std::vector<Eigen::Vector2d> CurvePixels(PointAt point_at) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(kBins);
  for (int k = 0; k < kBins; ++k) out.push_back(point_at(2 * M_PI * k / kBins));
  return out;
}

}  // namespace

double RingBoundary::RadiusAt(double phi) const {
  const int n = static_cast<int>(radius.size());
  double x = (phi + M_PI) / (2 * M_PI) * n;
  x -= n * std::floor(x / n);
  const int k0 = static_cast<int>(x) % n, k1 = (k0 + 1) % n;
  const double t = x - std::floor(x);
  return radius[k0] + t * (radius[k1] - radius[k0]);
}

double RingBoundary::MinRadius() const { return *std::min_element(radius.begin(), radius.end()); }
double RingBoundary::MaxRadius() const { return *std::max_element(radius.begin(), radius.end()); }

namespace {

// A single mirror's one ring: between the images of r_cam (`hole`: the camera's own reflection)
// and r_sys, its painted lip beyond where the model has one (HasLip; else lip1_outer is the rim).
// The folded rig's other curves collapse onto the hole (nothing is ring 2, the reflex disc or
// the plane beside it), so LabelAt and DepthInRing read a single rig unchanged.
RingLayout SingleRingLayout(const RigModel& model) {
  const RigParams& rig = model.params();
  const Mirror1Path<double>& path = model.path1();
  auto on_mirror = [&](double r, double t) {
    const double x = r * std::cos(t), y = r * std::sin(t);
    return PixelOfPointInCam(path.cam, path.dist,
                             Eigen::Vector3d(path.cam_from_mirror * Eigen::Vector3d(x, y, path.sheet.Z(x, y))),
                             rig.lens);
  };
  RingLayout layout;
  layout.width = rig.image_width;
  layout.height = rig.image_height;
  const auto rim = CurvePixels([&](double t) { return on_mirror(rig.r_sys, t); });
  for (const auto& p : rim) layout.centre += p / rim.size();
  layout.mirror1_rim = ToBoundary(rim, layout.centre);
  layout.lip1_outer = layout.mirror1_rim;
  if (HasLip(rig, Mirror::kOne)) {
    layout.lip1_outer = ToBoundary(CurvePixels([&](double t) {
      const Eigen::Vector3d lip(rig.lip1.r_outer * std::cos(t), rig.lip1.r_outer * std::sin(t), rig.lip1.z);
      return PixelOfPointInCam(path.cam, path.dist, Eigen::Vector3d(path.cam_from_mirror * lip), rig.lens);
    }), layout.centre);
  }
  layout.hole = ToBoundary(CurvePixels([&](double t) { return on_mirror(rig.r_cam, t); }), layout.centre);
  layout.mirror2_rim = layout.lip2_outer = layout.reflex_edge = layout.mirror1_cut = layout.hole;
  return layout;
}

}  // namespace

RingLayout ComputeRingLayout(const RigModel& model) {
  const RigParams& rig = model.params();
  if (rig.Single()) return SingleRingLayout(model);
  const Pose<double>& cam_from_mirror1 = model.path1().cam_from_mirror;
  const Pose<double>& cam_from_mirror2 = model.path2().cam_from_mirror;
  const HyperboloidSheet<double>& sheet1 = model.path1().sheet.conic;
  const HyperboloidSheet<double>& sheet2 = model.path2().sheet.conic;
  auto ring_in = [](const Pose<double>& cam_from_body, double r, double z, double t) {
    return Eigen::Vector3d(cam_from_body * Eigen::Vector3d(r * std::cos(t), r * std::sin(t), z));
  };

  RingLayout layout;
  layout.width = rig.image_width;
  layout.height = rig.image_height;
  const auto rim1 = CurvePixels([&](double t) {
    return DirectPixel(model, ring_in(cam_from_mirror1, rig.r_sys, sheet1.Z(rig.r_sys), t));
  });
  for (const auto& p : rim1) layout.centre += p / rim1.size();

  layout.mirror1_rim = ToBoundary(rim1, layout.centre);
  layout.lip1_outer = ToBoundary(CurvePixels([&](double t) {
    return DirectPixel(model, ring_in(cam_from_mirror1, rig.lip1.r_outer, rig.lip1.z, t));
  }), layout.centre);
  // The reflex disc: centre + R(rx, ry) (x, y, 0) in M1 (rig_frames.h).
  const Plane<double> reflex_in_mirror1 = ReflexPlaneInMirror1(rig.reflex.data(), rig.d);
  layout.reflex_edge = ToBoundary(CurvePixels([&](double t) {
    return DirectPixel(model, cam_from_mirror1 * ReflexRimInMirror1(rig.reflex.data(), rig.d,
                                                                    rig.r_ref, t));
  }), layout.centre);
  layout.mirror1_cut = ToBoundary(CurvePixels([&](double t) {
    // Bisection on r for the point of mirror 1 at azimuth t that lies on the reflex plane.
    auto side = [&](double r) {
      const Eigen::Vector3d p(r * std::cos(t), r * std::sin(t), sheet1.Z(r));
      return (p - reflex_in_mirror1.point).dot(reflex_in_mirror1.normal);
    };
    double lo = 0, hi = rig.r_sys;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (side(mid) > 0 ? lo : hi) = mid;  // below the plane: the cut lies further out
    }
    return DirectPixel(model, ring_in(cam_from_mirror1, lo, sheet1.Z(lo), t));
  }), layout.centre);
  layout.hole = ToBoundary(CurvePixels([&](double t) {
    return ViaReflexPixel(model, ring_in(cam_from_mirror2, rig.r_cam, sheet2.Z(rig.r_cam), t));
  }), layout.centre);
  layout.mirror2_rim = ToBoundary(CurvePixels([&](double t) {
    return ViaReflexPixel(model, ring_in(cam_from_mirror2, rig.r_sys, sheet2.Z(rig.r_sys), t));
  }), layout.centre);
  layout.lip2_outer = ToBoundary(CurvePixels([&](double t) {
    return ViaReflexPixel(model, ring_in(cam_from_mirror2, rig.lip2.r_outer, rig.lip2.z, t));
  }), layout.centre);
  return layout;
}

RingLabel RingLayout::LabelAt(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d d = pixel - centre;
  const double phi = std::atan2(d.y(), d.x()), r = d.norm();
  const double reflex = reflex_edge.RadiusAt(phi);
  if (r < hole.RadiusAt(phi)) return RingLabel::kHole;
  if (r < reflex) {  // what the reflex disc shows
    if (r < mirror2_rim.RadiusAt(phi)) return RingLabel::kMirror2;
    if (r < lip2_outer.RadiusAt(phi)) return RingLabel::kLip2;
    return RingLabel::kNone;
  }
  if (r < mirror1_cut.RadiusAt(phi)) return RingLabel::kNone;  // the plane beside the disc
  if (r < mirror1_rim.RadiusAt(phi)) return RingLabel::kMirror1;
  if (r < lip1_outer.RadiusAt(phi)) return RingLabel::kLip1;
  return RingLabel::kNone;
}

cv::Mat RingLayout::LabelMask() const {
  cv::Mat mask(height, width, CV_8U);
  for (int v = 0; v < height; ++v) {
    auto* row = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < width; ++u) {
      row[u] = static_cast<std::uint8_t>(LabelAt(Eigen::Vector2d(u, v)));
    }
  }
  return mask;
}

double RingLayout::DepthInRing(const Eigen::Vector2d& pixel, Mirror mirror) const {
  const Eigen::Vector2d d = pixel - centre;
  const double phi = std::atan2(d.y(), d.x()), r = d.norm();
  double lo, hi;
  if (mirror == Mirror::kOne) {
    lo = std::max(reflex_edge.RadiusAt(phi), mirror1_cut.RadiusAt(phi));
    hi = mirror1_rim.RadiusAt(phi);
  } else {
    lo = hole.RadiusAt(phi);
    hi = std::min(mirror2_rim.RadiusAt(phi), reflex_edge.RadiusAt(phi));
  }
  return std::min(r - lo, hi - r);
}

}  // namespace omni::detectors
