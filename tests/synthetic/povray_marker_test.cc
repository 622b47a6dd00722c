// Ties our projection maths to an independent ray tracer: small self-lit spheres rendered by
// POV-Ray through the rig; their intensity-weighted image centroids must agree with Project.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model/central_mirror.h"
#include "model/ideal_model.h"
#include "model/model_derived.h"
#include "model/rig_model.h"
#include "model/rig_params.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"

namespace omni {
namespace {

RigParams BigRigIdeal() {
  return MakeIdealRig(DesignParams{123.488, 241.803, 5.7319, 9.7443, 233.684, 37.0}, 7.0,
                      Pinhole<double>{1450, 1450, 639.5, 479.5, 0}, 1280, 960);
}

// The paper's big rig as built (sample_configs/big_rig_misaligned.yaml): decentres and tilts on
// both mirrors and the reflex disc, principal point off centre, skew, lens distortion.
RigParams BigRigMisaligned() {
  RigParams rig = BigRigIdeal();
  rig.kind = ModelKind::kNoncentral;
  rig.camera = {1452.5, 1451.0, 642.3, 476.8, 0.4};
  rig.distortion = {-0.02, 0.005, 0.0003, -0.0002, 0.0};
  rig.mirror1_pose = {0.003, -0.005, 0.3, -0.2, 0.4};
  rig.mirror2_pose = {-0.004, 0.002, -0.25, 0.35, -0.3};
  rig.reflex = {0.004, -0.003, 0.15};
  return rig;
}

// Intensity-weighted centroid of a window (linear intensities) above the window border's mean.
bool Centroid(const cv::Mat& grey, const Eigen::Vector2d& around, int half, Eigen::Vector2d* c) {
  const int u0 = static_cast<int>(std::lround(around.x())), v0 = static_cast<int>(std::lround(around.y()));
  if (u0 - half < 0 || v0 - half < 0 || u0 + half >= grey.cols || v0 + half >= grey.rows) return false;
  double border = 0;
  int n_border = 0;
  for (int k = -half; k <= half; ++k) {
    border += grey.at<float>(v0 - half, u0 + k) + grey.at<float>(v0 + half, u0 + k) +
              grey.at<float>(v0 + k, u0 - half) + grey.at<float>(v0 + k, u0 + half);
    n_border += 4;
  }
  border /= n_border;
  double s = 0, su = 0, sv = 0;
  for (int v = v0 - half; v <= v0 + half; ++v) {
    for (int u = u0 - half; u <= u0 + half; ++u) {
      const double w = std::max(0.0, grey.at<float>(v, u) - border);
      s += w;
      su += w * u;
      sv += w * v;
    }
  }
  if (s <= 0) return false;
  *c = Eigen::Vector2d(su / s, sv / s);
  return true;
}

struct MarkerStats {
  double mean = 0, max = 0;
  int n = 0;
};

// windows: POV-Ray renders only a window around each marker's predicted image (isosurfaces of
// profiled mirrors cost ~1 ms per pixel); the rig must then have no lens distortion (the
// distortion is applied to the whole rendered frame).
MarkerStats RenderAndCompare(const RigParams& rig, const std::string& tag, bool windows = false) {
  const RigModel model(rig);
  synthetic::SceneContent content;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 12; ++i) {
    const double az = i * 2 * M_PI / 12 + 0.2;
    const double range = 450 + 80 * (i % 4);
    const double z = 40 + 30 * ((i % 3) - 1);
    points.emplace_back(range * std::cos(az), range * std::sin(az), z);
    content.markers.push_back({points.back(), 0.015 * range});
  }
  const std::string dir = std::filesystem::temp_directory_path() / ("omni_markers_" + tag);
  std::filesystem::create_directories(dir);
  synthetic::RenderOptions opt;
  opt.width = rig.image_width;
  opt.height = rig.image_height;
  std::string error;
  const std::string png = dir + "/markers.png";
  const std::string pov = synthetic::PovSceneText(rig, content);
  cv::Mat grey;
  auto load = [&](const std::string& file) {
    cv::Mat img = synthetic::ApplyDistortion(cv::imread(file, cv::IMREAD_UNCHANGED), rig);
    EXPECT_FALSE(img.empty());
    cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(grey, CV_32F);
  };
  if (!windows) {
    EXPECT_TRUE(synthetic::RenderScene(pov, png, opt, &error)) << error;
    load(png);
  }
  MarkerStats stats;
  for (const auto& p : points) {
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      Eigen::Vector2d c;
      const auto projected = model.Project(p, m);
      if (!projected) continue;
      const Eigen::Vector2d px = *projected;
      if (windows) {
        const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
        opt.col0 = std::max(0, u - 12), opt.col1 = std::min(rig.image_width, u + 13);
        opt.row0 = std::max(0, v - 12), opt.row1 = std::min(rig.image_height, v + 13);
        EXPECT_TRUE(synthetic::RenderScene(pov, png, opt, &error)) << error;
        load(png);
      }
      if (!Centroid(grey, px, 9, &c)) continue;
      const double e = (c - px).norm();
      std::printf("%s mirror %d predicted (%.3f, %.3f) centroid (%.3f, %.3f) error %.3f px\n",
                  tag.c_str(), MirrorIndex(m), px.x(), px.y(), c.x(), c.y(), e);
      stats.mean += e;
      stats.max = std::max(stats.max, e);
      ++stats.n;
    }
  }
  stats.mean /= std::max(1, stats.n);
  return stats;
}

TEST(PovRayMarkers, IdealRigCentroidsMatchProjection) {
  const MarkerStats s = RenderAndCompare(BigRigIdeal(), "ideal");
  std::printf("ideal rig: %d marker images, mean %.4f px, max %.4f px\n", s.n, s.mean, s.max);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
}

TEST(PovRayMarkers, MisalignedRigCentroidsMatchNoncentralProjection) {
  const MarkerStats s = RenderAndCompare(BigRigMisaligned(), "misaligned");
  std::printf("misaligned rig: %d marker images, mean %.4f px, max %.4f px\n", s.n, s.mean, s.max);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
}

}  // namespace
}  // namespace omni

namespace omni {
namespace {

// Machined mirrors (issue 40): POV-Ray draws a profiled mirror as an isosurface of the model's
// own surface; the markers' centroids must follow the profiled projection, which the exact
// quadrics' projection misses by a pixel.
TEST(PovRayMarkers, ProfiledMirrorsCentroidsMatchProfiledProjection) {
  RigParams rig = BigRigMisaligned();
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.profile2 = DefaultProfileShape(rig, Mirror::kTwo);
  rig.mirror1_profile = {0.006, -0.002, 0.001, 0, 0.002, 0};
  rig.mirror2_profile = {-0.005, 0.002, 0, 0, 0, 0.002};
  rig.profile1.ripple_amplitude = 0.002;
  rig.profile1.ripple_period = 6;
  rig.distortion = {0, 0, 0, 0, 0};  // windows (see RenderAndCompare)
  const MarkerStats s = RenderAndCompare(rig, "profiled", /*windows=*/true);
  std::printf("profiled rig: %d marker images, mean %.4f px, max %.4f px\n", s.n, s.mean, s.max);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
  // The test can fail: the same markers through the exact quadrics land far off.
  RigParams exact = rig;
  exact.profile1.present = exact.profile2.present = false;
  const RigModel with(rig), without(exact);
  double moved = 0;
  int n = 0;
  for (int i = 0; i < 12; ++i) {
    const double az = i * 2 * M_PI / 12 + 0.2, range = 450 + 80 * (i % 4), z = 40 + 30 * ((i % 3) - 1);
    const Eigen::Vector3d p(range * std::cos(az), range * std::sin(az), z);
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      const auto a = with.Project(p, m), b = without.Project(p, m);
      if (a && b) moved += (*a - *b).norm(), ++n;
    }
  }
  std::printf("the profile moves the markers by %.3f px on average\n", moved / n);
  EXPECT_GT(moved / n, std::max(0.2, 5 * s.mean));
}

}  // namespace
}  // namespace omni

namespace omni {
namespace {

// The prototype's mount (issue 39): where the model says a post blocks every path to a marker
// (125 probes over its sphere's cube), POV-Ray's image shows no marker there; where it says every
// path is free, the marker is there: the centroid of its pixels above half its brightness (the
// grey post beside it, 0.25, left out) within 0.3 px of the projection.
TEST(PovRayMarkers, MountPostsHideWhatTheModelSaysTheyBlock) {
  RigParams rig = BigRigMisaligned();
  rig.distortion = {0, 0, 0, 0, 0};
  rig.mount.present = true;
  rig.mount.width = 3.0;
  rig.mount.radius = 41.5;
  rig.mount.z_min = rig.lip2.z;
  rig.mount.z_max = rig.lip1.z;
  rig.mount.azimuths = {M_PI / 2, M_PI / 2 + 2 * M_PI / 3, M_PI / 2 + 4 * M_PI / 3};
  RigParams open = rig;
  open.mount.present = false;
  const RigModel with(rig), without(open);
  synthetic::SceneContent content;
  struct Case {
    Eigen::Vector3d point;
    Mirror mirror;
    bool blocked;
    Eigen::Vector2d pixel;
  };
  std::vector<Case> cases;
  int n_blocked = 0, n_free = 0;
  for (int i = 0; i < 4000 && (n_blocked < 8 || n_free < 8); ++i) {
    const double az = rig.mount.azimuths[i % 3] + 0.003 * ((i / 3) % 41 - 20);
    const double range = 500 + 40 * (i % 7), z = -150 + 25 * (i % 13);
    const Eigen::Vector3d p(range * std::cos(az), range * std::sin(az), z);
    const double r = 0.015 * range;
    for (Mirror m : {Mirror::kOne, Mirror::kTwo}) {
      const auto px = without.Project(p, m);
      if (!px) continue;
      // Probes on a 5 x 5 x 5 grid over the sphere's bounding cube (a little larger).
      int valid = 0, probes = 0;
      for (int a = -2; a <= 2; ++a) {
        for (int b = -2; b <= 2; ++b) {
          for (int c = -2; c <= 2; ++c) {
            ++probes;
            valid += with.Project(p + 0.65 * r * Eigen::Vector3d(a, b, c), m).has_value();
          }
        }
      }
      // Markers apart in the image (their windows must not overlap).
      bool apart = true;
      for (const Case& c : cases) apart &= (c.pixel - *px).norm() > 30;
      if (!apart) continue;
      if (valid == 0 && n_blocked < 8) {
        cases.push_back({p, m, true, *px}), ++n_blocked;
      } else if (valid == probes && n_free < 8) {
        cases.push_back({p, m, false, *px}), ++n_free;
      }
    }
  }
  ASSERT_GE(n_blocked, 4);
  ASSERT_GE(n_free, 4);
  for (const Case& c : cases) content.markers.push_back({c.point, 0.015 * c.point.head<2>().norm()});
  const std::string dir = std::filesystem::temp_directory_path() / "omni_markers_mount";
  std::filesystem::create_directories(dir);
  synthetic::RenderOptions opt;
  opt.width = rig.image_width;
  opt.height = rig.image_height;
  std::string error;
  ASSERT_TRUE(synthetic::RenderScene(synthetic::PovSceneText(rig, content), dir + "/m.png", opt, &error))
      << error;
  cv::Mat img = cv::imread(dir + "/m.png", cv::IMREAD_UNCHANGED), grey;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_32F, 1.0 / 255);
  for (const Case& c : cases) {
    const int u = static_cast<int>(std::lround(c.pixel.x())), v = static_cast<int>(std::lround(c.pixel.y()));
    double peak = 0;
    for (int dv = -6; dv <= 6; ++dv) {
      for (int du = -6; du <= 6; ++du) peak = std::max(peak, double(grey.at<float>(v + dv, u + du)));
    }
    // Centroid of the marker's pixels above 0.5 (the post beside it is 0.25).
    double sw = 0, su = 0, sv = 0;
    for (int dv = -9; dv <= 9; ++dv) {
      for (int du = -9; du <= 9; ++du) {
        const double w = std::max(0.0, double(grey.at<float>(v + dv, u + du)) - 0.5);
        sw += w, su += w * (u + du), sv += w * (v + dv);
      }
    }
    const bool found = sw > 0;
    const Eigen::Vector2d centroid = found ? Eigen::Vector2d(su / sw, sv / sw) : c.pixel;
    std::printf("mount: mirror %d %s at (%.1f, %.1f): peak %.2f%s\n", MirrorIndex(c.mirror),
                c.blocked ? "blocked" : "free", c.pixel.x(), c.pixel.y(), peak,
                found && !c.blocked ? (" centroid error " + std::to_string((centroid - c.pixel).norm()) + " px").c_str() : "");
    if (c.blocked) {
      EXPECT_LT(peak, 0.5) << "a marker the model says a post hides is seen";
    } else {
      EXPECT_GT(peak, 0.5);
      ASSERT_TRUE(found);
      EXPECT_LT((centroid - c.pixel).norm(), 0.3);
    }
  }
}

}  // namespace
}  // namespace omni

namespace omni {
namespace {

// Single-mirror rigs (issue 47): POV-Ray draws the conic itself (a quadric clipped to the branch
// through the vertex and to r_cam..r_sys) and, for a telecentric lens, an orthographic camera.
// Markers around each rig, sized to about 2 px of image radius, at 320x256: their centroids must
// follow RigModel::Project as the folded rig's do (mean 0.05 px, max 0.15 px).

// sample_configs/single_*.yaml (a 60 mm rim at 1280x1024) at 320x256 and misaligned: the axis
// tilted 0.51 deg, the mirror shifted 0.54 mm.
RigParams SmallSingleRig(const Conic<double>& mirror, LensKind lens, double vertex_z, double r_cam,
                         double focal_full_size, const std::array<double, 5>& distortion) {
  const RigParams full = MakeSingleRig(mirror, lens, vertex_z, 30.0, r_cam,
                                       Pinhole<double>{focal_full_size, focal_full_size, 639.5, 511.5, 0},
                                       1280, 1024);
  RigParams rig = synthetic::RigAtImageSize(full, 320, 256);
  rig.kind = ModelKind::kNoncentral;
  rig.mirror1_pose = {0.006, -0.0065, 0.4, -0.3, 0.2};
  rig.camera[kCx] += 1.3, rig.camera[kCy] -= 0.8;
  rig.distortion = distortion;
  return rig;
}

RigParams SmallHyperbolic() {
  CentralMirror central{Conic<double>{30.0, -1.8}, LensKind::kPerspective, 0, 0};
  return SmallSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(), 6.0, 1600,
                        {-0.03, 0.01, 2e-4, -1e-4, 0});
}

RigParams SmallParabolic() {
  // Telecentric: 16 px per mm at 1280x1024; distortion in mm (fx maps mm to px).
  return SmallSingleRig(Conic<double>{24.0, -1.0}, LensKind::kTelecentric, 80.0, 4.0, 16.0,
                        {1.5e-5, 0, 1e-5, -1e-5, 0});
}

RigParams SmallSpherical() {
  return SmallSingleRig(Conic<double>{40.0, 0.0}, LensKind::kPerspective, 100.0, 5.0, 1800,
                        {0, 0, 0, 0, 0});
}

struct SingleMarkers {
  synthetic::SceneContent content;
  std::vector<Eigen::Vector2d> pixels;
};

// Markers 0.4-1.3 m from the mirror's near focus, 45 deg below to 8 deg above its level, each
// seen whole inside the mirror's annulus, their images at least 24 px apart (the centroid
// windows must not overlap).
SingleMarkers PlaceSingleMarkers(const RigParams& rig) {
  const RigModel model(rig);
  const Eigen::Vector3d focus = ComputeModelDerived(rig).focus1_in_cam;
  SingleMarkers out;
  const double elevations_deg[] = {-45, -32, -20, -8, 4, 8};
  for (int e = 0; e < 6; ++e) {
    for (int k = 0; k < 12; ++k) {
      const double el = elevations_deg[e] * M_PI / 180, az = 2 * M_PI * (k + 0.37 * e) / 12;
      const double range = 400 + 300 * ((k + e) % 4);
      const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      const Eigen::Vector3d p = focus + range * dir;
      const auto px = model.Project(p, Mirror::kOne);
      if (!px || px->x() < 12 || px->y() < 12 || px->x() > rig.image_width - 13 ||
          px->y() > rig.image_height - 13) {
        continue;
      }
      // Image scale (px per mm) across the line of sight, for a marker of ~2 px image radius.
      const Eigen::Vector3d across[2] = {Eigen::Vector3d(-std::sin(az), std::cos(az), 0),
                                         dir.cross(Eigen::Vector3d(-std::sin(az), std::cos(az), 0))};
      double scale = 0;
      bool whole = true;
      for (const Eigen::Vector3d& a : across) {
        const auto q = model.Project(p + 0.01 * range * a, Mirror::kOne);
        whole &= q.has_value();
        if (q) scale = std::max(scale, (*q - *px).norm() / (0.01 * range));
      }
      if (!whole || scale <= 0) continue;
      const double radius = 2.0 / scale;
      for (int i = 0; i < 3 && whole; ++i) {
        for (double sign : {-1.0, 1.0}) {
          whole &= model.Project(p + sign * 1.5 * radius * Eigen::Vector3d::Unit(i), Mirror::kOne).has_value();
        }
      }
      bool apart = true;
      for (const Eigen::Vector2d& other : out.pixels) apart &= (other - *px).norm() > 24;
      if (!whole || !apart) continue;
      out.content.markers.push_back({p, radius});
      out.pixels.push_back(*px);
    }
  }
  return out;
}

// n of the markers, spread over all their elevations (PlaceSingleMarkers' order).
SingleMarkers Spread(const SingleMarkers& all, int n) {
  SingleMarkers out;
  const int size = static_cast<int>(all.pixels.size());
  for (int i = 0; i < std::min(n, size); ++i) {
    out.content.markers.push_back(all.content.markers[i * size / std::min(n, size)]);
    out.pixels.push_back(all.pixels[i * size / std::min(n, size)]);
  }
  return out;
}

// max_windows > 0: POV-Ray renders only a window around each of max_windows markers' images
// (a profiled mirror's isosurface is slow; RenderAndCompare), so no lens distortion.
MarkerStats RenderSingleAndCompare(const RigParams& rig, const std::string& tag,
                                   int max_windows = 0) {
  const SingleMarkers markers =
      max_windows > 0 ? Spread(PlaceSingleMarkers(rig), max_windows) : PlaceSingleMarkers(rig);
  const std::string dir = std::filesystem::temp_directory_path() / ("omni_markers_" + tag);
  std::filesystem::create_directories(dir);
  synthetic::RenderOptions opt;
  opt.width = rig.image_width;
  opt.height = rig.image_height;
  std::string error;
  const std::string png = dir + "/markers.png";
  const std::string pov = synthetic::PovSceneText(rig, markers.content);
  cv::Mat grey;
  const auto render = [&]() {
    EXPECT_TRUE(synthetic::RenderScene(pov, png, opt, &error)) << error;
    const cv::Mat img = synthetic::ApplyDistortion(cv::imread(png, cv::IMREAD_UNCHANGED), rig);
    EXPECT_FALSE(img.empty());
    if (img.empty()) return false;
    cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(grey, CV_32F);
    return true;
  };
  if (max_windows == 0 && !render()) return {};
  MarkerStats stats;
  for (const Eigen::Vector2d& px : markers.pixels) {
    if (max_windows > 0) {
      const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
      opt.col0 = std::max(0, u - 12), opt.col1 = std::min(rig.image_width, u + 13);
      opt.row0 = std::max(0, v - 12), opt.row1 = std::min(rig.image_height, v + 13);
      if (!render()) return {};
    }
    Eigen::Vector2d c;
    if (!Centroid(grey, px, 9, &c)) continue;
    const double e = (c - px).norm();
    std::printf("%s predicted (%.3f, %.3f) centroid (%.3f, %.3f) error %.3f px\n", tag.c_str(),
                px.x(), px.y(), c.x(), c.y(), e);
    stats.mean += e;
    stats.max = std::max(stats.max, e);
    ++stats.n;
  }
  stats.mean /= std::max(1, stats.n);
  std::printf("%s: %d markers, mean %.4f px, max %.4f px\n", tag.c_str(), stats.n, stats.mean,
              stats.max);
  return stats;
}

// The test can fail: the misalignment moves the markers' images well beyond the tolerance.
double MeanShiftFromAligned(const RigParams& rig) {
  RigParams aligned = rig;
  aligned.mirror1_pose = {0, 0, 0, 0, 0};
  const RigModel with(rig), without(aligned);
  double moved = 0;
  int n = 0;
  for (const synthetic::Marker& m : PlaceSingleMarkers(rig).content.markers) {
    const auto a = with.Project(m.center_in_cam, Mirror::kOne), b = without.Project(m.center_in_cam, Mirror::kOne);
    if (a && b) moved += (*a - *b).norm(), ++n;
  }
  return moved / std::max(1, n);
}

void ExpectSingleRigMatches(const RigParams& rig, const std::string& tag) {
  const MarkerStats s = RenderSingleAndCompare(rig, tag);
  EXPECT_GE(s.n, 20);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
  const double moved = MeanShiftFromAligned(rig);
  std::printf("%s: the misalignment moves the markers by %.3f px on average\n", tag.c_str(), moved);
  EXPECT_GT(moved, 10 * 0.05);
}

TEST(PovRayMarkers, SingleHyperbolicPerspectiveMatchesProjection) {
  ExpectSingleRigMatches(SmallHyperbolic(), "single_hyperbolic");
}

TEST(PovRayMarkers, SingleParabolicTelecentricMatchesProjection) {
  ExpectSingleRigMatches(SmallParabolic(), "single_parabolic");
}

TEST(PovRayMarkers, SingleSphericalPerspectiveMatchesProjection) {
  ExpectSingleRigMatches(SmallSpherical(), "single_spherical");
}

// A machined single mirror (issue 47: the profile terms on any conic): POV-Ray draws the conic's
// sag plus the profile as an isosurface; 10 markers' centroids follow the profiled projection,
// which the exact conic's misses by more than 5 times their error.
TEST(PovRayMarkers, SingleProfiledMirrorMatchesProfiledProjection) {
  RigParams rig = SmallHyperbolic();
  rig.distortion = {0, 0, 0, 0, 0};  // windows (RenderSingleAndCompare)
  rig.profile1 = DefaultProfileShape(rig, Mirror::kOne);
  rig.mirror1_profile = {0.03, -0.01, 0.005, 0, 0.01, 0};
  // The folded test's 2 um ripple: at 5 um its curvature across a marker's footprint on the
  // mirror bends two rim markers' images by 0.09 px (mean 0.053 px), a bias of the markers'
  // finite size, not of the surface (the isosurface of the bare conic: mean 0.024 px).
  rig.profile1.ripple_amplitude = 0.002;
  rig.profile1.ripple_period = 6;
  const MarkerStats s = RenderSingleAndCompare(rig, "single_profiled", /*max_windows=*/10);
  EXPECT_GE(s.n, 10);
  EXPECT_LT(s.mean, 0.05);
  EXPECT_LT(s.max, 0.15);
  RigParams exact = rig;
  exact.profile1.present = false;
  const RigModel with(rig), without(exact);
  double moved = 0;
  for (const synthetic::Marker& m : Spread(PlaceSingleMarkers(rig), 10).content.markers) {
    const Eigen::Vector3d& p = m.center_in_cam;
    moved += (*with.Project(p, Mirror::kOne) - *without.Project(p, Mirror::kOne)).norm() / 10;
  }
  std::printf("the profile moves the markers by %.3f px on average\n", moved);
  EXPECT_GT(moved, std::max(0.2, 5 * s.mean));
}

}  // namespace
}  // namespace omni
