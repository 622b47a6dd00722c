// A single mirror's rim measured in a POV-Ray render (detectors/lips/rim_edge.h): POV-Ray draws
// the conic clipped at r_sys, so the edge of the mirror's image is the true rim; the oracle is the
// true model's rim curve (model/lip.h ProjectLipPoint, direct, at the conic's sag), the detector
// searches from a model a few pixels off. Hyperboloid + perspective lens and paraboloid +
// telecentric lens, both misaligned, in a textured room at 640x512. POV-Ray draws a dark 3 mm
// flange at the rim: where the mirror's outer zone reflects rays past the rim's plane (a
// paraboloid whose rim is steeper than 45 deg, a sphere) the flange is seen in it and the
// image's edge lies inside the rim, which model/single_rim.h RimEdgeIsTheRim predicts.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/common/views.h"
#include "detectors/lips/rim_edge.h"
#include "io/image_file.h"
#include "model/central_mirror.h"
#include "model/lip.h"
#include "model/single_rim.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "tests/render_room.h"

namespace omni::detectors {
namespace {

RigParams Small(RigParams full) {
  RigParams rig = synthetic::RigAtImageSize(full, 640, 512);
  rig.kind = ModelKind::kNoncentral;
  rig.mirror1_pose = {0.006, -0.0065, 0.4, -0.3, 0.2};
  return rig;
}

RigParams Hyperbolic() {
  CentralMirror central{Conic<double>{30.0, -1.8}, LensKind::kPerspective, 0, 0};
  return Small(MakeSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(), 30.0, 6.0,
                             Pinhole<double>{1600, 1600, 641.5, 509.5, 0}, 1280, 1024));
}

// R 40: the rim's slope 0.75, its reflected rays head to the camera's side; R 24: slope 1.25.
RigParams Parabolic(double r_mm = 40.0) {
  return Small(MakeSingleRig(Conic<double>{r_mm, -1.0}, LensKind::kTelecentric, 80.0, 30.0, 4.0,
                             Pinhole<double>{16.0, 16.0, 641.5, 509.5, 0}, 1280, 1024));
}

RigParams Spherical() {
  return Small(MakeSingleRig(Conic<double>{40.0, 0.0}, LensKind::kPerspective, 100.0, 30.0, 5.0,
                             Pinhole<double>{1800, 1800, 641.5, 509.5, 0}, 1280, 1024));
}

// The true rim's image, densely sampled.
std::vector<Eigen::Vector2d> RimCurve(const RigParams& rig) {
  const RigModel model(rig);
  std::vector<Eigen::Vector2d> curve;
  for (int k = 0; k < 7200; ++k) {
    Eigen::Vector2d px;
    if (ProjectLipPoint(RigBlocksOf(rig), model.fixed(), LipPath::kDirect, rig.r_sys,
                        SingleRimZ(rig), 2 * M_PI * k / 7200, &px)) {
      curve.push_back(px);
    }
  }
  return curve;
}

struct Offsets {
  double mean = 0, rms = 0;  // px, + outside the rim
};

// Each point's radial offset from the nearest sample of `curve` (samples ~0.3 px apart).
Offsets OffsetsFromCurve(const std::vector<Eigen::Vector2d>& points,
                         const std::vector<Eigen::Vector2d>& curve) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& c : curve) centre += c / static_cast<double>(curve.size());
  Offsets out;
  for (const Eigen::Vector2d& p : points) {
    const Eigen::Vector2d* nearest = &curve.front();
    for (const Eigen::Vector2d& c : curve) {
      if ((c - p).squaredNorm() < (*nearest - p).squaredNorm()) nearest = &c;
    }
    const double offset = (p - centre).norm() - (*nearest - centre).norm();
    out.mean += offset / static_cast<double>(points.size());
    out.rms += offset * offset / static_cast<double>(points.size());
  }
  out.rms = std::sqrt(out.rms);
  return out;
}

cv::Mat RenderGrey(const RigParams& rig, const std::string& tag) {
  const cv::Mat colour = testing::RenderRoom(rig, "rim_edge_" + tag);
  if (colour.empty()) return colour;
  // As DetectImage gives it: linear light (the renders are sRGB), grey.
  return ToGrey(io::LinearImage(colour, io::ToneCurve::kSrgb));
}

// The rim's edge found from a start 2-3 px off (the start model's rim fit is ~1 px off).
Offsets FindRim(const RigParams& truth, const std::string& tag, size_t* points, double band_px = 0) {
  const cv::Mat grey = RenderGrey(truth, tag);
  EXPECT_FALSE(grey.empty());
  if (grey.empty()) return {};
  RigParams start = truth;
  start.camera[kCx] += 2.0;
  start.camera[kCy] -= 1.5;
  start.camera[kFx] *= 1.006, start.camera[kFy] *= 1.006;
  const std::vector<Eigen::Vector2d> curve = RimCurve(truth);
  EXPECT_GT(curve.size(), 7000u);
  const Offsets start_off = OffsetsFromCurve(RimCurve(start), curve);
  EXPECT_GT(start_off.rms, 1.5);  // the search does not just return its start
  std::string why;
  RimEdgeOptions options;
  options.min_coverage = 0.1;
  if (band_px > 0) options.min_band_px = band_px;
  const auto rim = DetectRimEdge(grey, RigModel(start), options, &why);
  EXPECT_TRUE(rim.has_value()) << why;
  if (!rim) return {};
  EXPECT_EQ(rim->mirror, Mirror::kOne);
  EXPECT_EQ(rim->path, LipPath::kDirect);
  EXPECT_EQ(rim->circle, LipCircle::kOuter);
  *points = rim->points.size();
  const Offsets found = OffsetsFromCurve(rim->points, curve);
  std::printf("%s: %zu rim points, %.3f px from the true rim on average, rms %.3f px (the "
              "start's rim: rms %.3f px)\n", tag.c_str(), rim->points.size(), found.mean,
              found.rms, start_off.rms);
  return found;
}

void ExpectRimFound(const RigParams& truth, const std::string& tag) {
  double elevation = 0;
  EXPECT_TRUE(RimEdgeIsTheRim(RigModel(truth), &elevation)) << elevation << " deg";
  size_t points = 0;
  const Offsets found = FindRim(truth, tag, &points);
  EXPECT_GT(points, 0.7 * RimEdgeOptions{}.rays);
  // The room's texture up to the rim (features of 2-3 px at 640x512) moves single points, and
  // inwards only (the housing outside is plain): 0.4 px is 0.17% of the rim's radius.
  EXPECT_LT(std::abs(found.mean), 0.4);
  EXPECT_LT(found.rms, 0.8);
}

TEST(RimEdge, HyperboloidWithPerspectiveLens) { ExpectRimFound(Hyperbolic(), "hyperbolic"); }

TEST(RimEdge, ParaboloidWithTelecentricLens) { ExpectRimFound(Parabolic(), "parabolic"); }

// A steep paraboloid and a sphere: RimEdgeIsTheRim says no, and the image's edge is indeed the
// flange's reflection, pixels inside the rim.
TEST(RimEdge, WhereTheRimLooksBackItsEdgeIsTheHolders) {
  for (const auto& [rig, tag] : {std::pair{Parabolic(24.0), "steep_parabolic"},
                                 std::pair{Spherical(), "spherical"}}) {
    double elevation = 0;
    EXPECT_FALSE(RimEdgeIsTheRim(RigModel(rig), &elevation)) << tag;
    EXPECT_GT(elevation, 5) << tag;
    size_t points = 0;
    // A wider search: the edges lie ~4.5 px inside the rim at 640x512, the start 2.3 px off.
    EXPECT_LT(FindRim(rig, tag, &points, 8.0).mean, -2.0) << tag;
  }
}

TEST(RimEdge, NoRimInABlankImageAndBadOptionsNamed) {
  const RigParams rig = Hyperbolic();
  std::string why;
  const cv::Mat blank(rig.image_height, rig.image_width, CV_8UC1, cv::Scalar(90));
  EXPECT_FALSE(DetectRimEdge(blank, RigModel(rig), RimEdgeOptions{}, &why).has_value());
  EXPECT_NE(why.find("rays"), std::string::npos) << why;
  RimEdgeOptions bad;
  bad.rays = 4;
  EXPECT_THROW(DetectRimEdge(blank, RigModel(rig), bad), std::invalid_argument);
}

}  // namespace
}  // namespace omni::detectors
