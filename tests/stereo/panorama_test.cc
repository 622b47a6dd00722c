// Panorama look-up tables (stereo/panorama.h) and the PLY writer against independent
// checks: the model's own back projection of each LUT pixel, and the panorama position of 3D
// points computed from the cylinder geometry.
#include "stereo/panorama.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include <unistd.h>

#include "io/file_util.h"
#include "io/model_file.h"
#include "io/ply.h"
#include "model/central_mirror.h"
#include "model/model_derived.h"

namespace omni::stereo {
namespace {

const std::string kSampleDir = std::string(OMNI_SOURCE_DIR) + "/sample_configs/";

// Distance from point p to the ray (origin, unit direction).
double DistanceToRay(const Ray& ray, const Eigen::Vector3d& p) {
  const Eigen::Vector3d w = p - ray.origin;
  return (w - w.dot(ray.direction) * ray.direction).norm();
}

// Every valid LUT entry is the raw pixel whose ray (RigModel::Unproject, the exact tracer, not
// the Project code that built the LUT) passes through the panorama pixel's cylinder point.
TEST(Panorama, LutPixelsSeeTheirCylinderPoints) {
  for (const char* rig : {"big_rig_ideal.yaml", "big_rig_misaligned.yaml"}) {
    const RigModel model(io::ReadModelFile(kSampleDir + rig));
    PanoramaOptions options;
    options.width = 360;
    const PanoramaLuts luts = BuildPanoramaLuts(model, options);
    const PanoramaGeometry& g = luts.geometry;
    // [cylinder_height], [panorama_pixel_size]: h = w (tan max - tan min) / 2 pi.
    EXPECT_NEAR(g.height, options.width * (g.z_max - g.z_min) / (2 * M_PI), 0.5);
    int checked = 0, lost = 0, valid[2] = {0, 0};
    double worst = 0;
    for (int i = 0; i < 2; ++i) {
      const Mirror mirror = i == 0 ? Mirror::kOne : Mirror::kTwo;
      for (int v = 0; v < g.height; v += 3) {
        for (int u = 0; u < g.width; u += 7) {
          const float x = luts.map_x[i].at<float>(v, u), y = luts.map_y[i].at<float>(v, u);
          if (x < 0) continue;
          ++valid[i];
          const auto ray = model.Unproject(Eigen::Vector2d(x, y));
          if (!ray) {  // the float-rounded pixel fell across a ring boundary
            ++lost;
            continue;
          }
          EXPECT_EQ(ray->mirror, mirror);
          const Eigen::Vector3d p = g.PointOnCylinder(mirror, u, v);
          // The LUT is stored in float: 1e-4 px of rounding at ~2 m is ~0.2 mm off the ray.
          worst = std::max(worst, DistanceToRay(ray->ray, p));
          ++checked;
          // The panorama pixel of the cylinder point is (u, v) again.
          EXPECT_LT((g.PanoramaPixel(mirror, p) - Eigen::Vector2d(u, v)).norm(), 1e-9);
        }
      }
    }
    std::printf("%s: %dx%d, %d LUT pixels checked (%d lost at ring edges), worst ray distance "
                "%.3g mm\n", rig, g.width, g.height, checked, lost, worst);
    // On the ideal rig the panorama's first and last rows lie exactly on the mirrors' rims
    // ([cylinder_height] uses the ideal elevation limits), where float rounding decides.
    EXPECT_LE(lost, checked / 100) << lost << " LUT pixels do not back-project";
    EXPECT_GT(valid[0], 100);
    EXPECT_GT(valid[1], 100);
    EXPECT_LT(worst, 0.5);
  }
}

// For scene points off the cylinder a non-central rig's LUT is not exact: measure how far the
// raw pixel of a point lands from the panorama pixel its direction from F_i predicts.
TEST(Panorama, NonCentralLutErrorIsSmallAwayFromTheCylinder) {
  const RigModel model(io::ReadModelFile(kSampleDir + "big_rig_misaligned.yaml"));
  PanoramaOptions options;
  options.width = 1280;
  const PanoramaLuts luts = BuildPanoramaLuts(model, options);
  const PanoramaGeometry& g = luts.geometry;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (double range : {500.0, 8000.0}) {
    double worst = 0;
    int n = 0;
    for (int k = 0; k < 200; ++k) {
      const int i = k % 2;
      const Mirror mirror = i == 0 ? Mirror::kOne : Mirror::kTwo;
      // A point at `range` from F_i in the direction of a random panorama pixel.
      const double u = 10 + u01(rng) * (g.width - 20), v = 10 + u01(rng) * (g.height - 20);
      const Eigen::Vector3d on_cylinder = g.PointOnCylinder(mirror, u, v);
      const Eigen::Vector3d f = g.viewpoint_in_cam[i];
      const Eigen::Vector3d point = f + range / g.radius_mm * (on_cylinder - f);
      const auto raw = model.Project(point, mirror);
      cv::Mat mx = luts.map_x[i], my = luts.map_y[i];
      // The LUT value at (u, v), bilinear.
      const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
      const double a = u - u0, b = v - v0;
      Eigen::Vector2d lut = Eigen::Vector2d::Zero();
      bool ok = raw.has_value();
      for (int dv = 0; dv < 2 && ok; ++dv) {
        for (int du = 0; du < 2 && ok; ++du) {
          const double w = (du ? a : 1 - a) * (dv ? b : 1 - b);
          const float x = mx.at<float>(v0 + dv, u0 + du), y = my.at<float>(v0 + dv, u0 + du);
          if (x < 0) ok = false;
          lut += w * Eigen::Vector2d(x, y);
        }
      }
      if (!ok) continue;
      worst = std::max(worst, (lut - *raw).norm());
      ++n;
    }
    std::printf("misaligned rig, points at %.0f mm from F_i (cylinder at %.0f mm): worst LUT "
                "error %.3f raw px over %d points\n",
                range, g.radius_mm, worst, n);
    EXPECT_GT(n, 100);
    // Bilinear LUT interpolation alone is ~0.01 px; the non-central part must stay small.
    EXPECT_LT(worst, 0.25);
  }
}

// A single-mirror rig's one panorama against the unified model's closed form
// (central_mirror.h): a perspective lens at an aligned hyperboloid's far focus is central, so each
// LUT entry is exactly the unified pixel of its cylinder point seen from the near focus, and the
// elevation limits (RigFieldOfView) are those of the rim (r_sys) and the hole (r_cam): their
// unified image radii equal the pinhole radii of those mirror points.
TEST(Panorama, SingleRigHasOnePanoramaOfTheUnifiedModel) {
  CentralMirror central;
  central.mirror = Conic<double>{20.0, -2.2};
  central.focal_px = 800;
  const double below = central.CameraBelowVertexMm(), r_sys = 30, r_cam = 5;
  const RigModel model(MakeSingleRig(central.mirror, LensKind::kPerspective, below, r_sys, r_cam,
                                     Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960));
  const UnifiedParameters unified = *UnifiedOf(central);
  double near = 0;
  ASSERT_TRUE(central.mirror.NearFocus(&near));
  const Eigen::Vector3d focus(0, 0, below + near);
  auto unified_pixel = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d v = (p - focus).normalized();
    return Eigen::Vector2d(640 + unified.gamma * v.x() / (unified.xi - v.z()),
                           480 + unified.gamma * v.y() / (unified.xi - v.z()));
  };
  // Elevation theta seen from the focus: image radius gamma cos(theta) / (xi - sin(theta)).
  const FieldOfView fov = RigFieldOfView(model.params());
  EXPECT_TRUE(std::isnan(fov.theta2_min) && std::isnan(fov.theta_sroi_max));
  EXPECT_EQ(fov.alpha_sys, fov.alpha1);
  for (const auto& [r, theta] : {std::pair{r_sys, fov.theta1_max}, {r_cam, fov.theta1_min}}) {
    const double z = below + central.mirror.Sag(r * r);
    EXPECT_NEAR(unified.gamma * std::cos(theta) / (unified.xi - std::sin(theta)), 800 * r / z,
                1e-9)
        << "r " << r;
  }

  PanoramaOptions options;
  options.width = 360;
  const PanoramaLuts luts = BuildPanoramaLuts(model, options);
  const PanoramaGeometry& g = luts.geometry;
  ASSERT_EQ(g.rings, 1);
  EXPECT_TRUE(luts.map_x[1].empty());
  EXPECT_NEAR((g.viewpoint_in_cam[0] - focus).norm(), 0, 1e-12);
  EXPECT_NEAR(std::atan(g.z_max), fov.theta1_max, 1e-12);
  EXPECT_NEAR(std::atan(g.z_min), fov.theta1_min, 1e-12);
  int valid = 0;
  double worst = 0;
  for (int v = 0; v < g.height; ++v) {
    for (int u = 0; u < g.width; ++u) {
      const float x = luts.map_x[0].at<float>(v, u), y = luts.map_y[0].at<float>(v, u);
      if (x < 0) continue;
      ++valid;
      const Eigen::Vector2d expected = unified_pixel(g.PointOnCylinder(Mirror::kOne, u, v));
      worst = std::max(worst, (Eigen::Vector2d(x, y) - expected).norm());
    }
  }
  // Every row but the limits' own (the rim and the hole, where a ray may just miss) is seen.
  EXPECT_GE(valid, (g.height - 2) * g.width);
  EXPECT_LT(worst, 2e-4) << "px (float32 LUT)";
  cv::Mat image(960, 1280, CV_8UC1, cv::Scalar(9)), panorama;
  EXPECT_THROW(Unwarp(image, luts, Mirror::kTwo, &panorama), std::invalid_argument);
  Unwarp(image, luts, Mirror::kOne, &panorama);
  EXPECT_EQ(panorama.rows, g.height);
}

TEST(Ply, BinaryAndAsciiRoundTripAndAtomicWrite) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("stereo_ply_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::vector<io::PlyPoint> points;
  for (int i = 0; i < 1000; ++i) {
    io::PlyPoint p;
    p.x = 0.5f * i;
    p.y = -1.25f * i;
    p.z = 1e4f + i;
    p.red = static_cast<std::uint8_t>(i);
    p.green = static_cast<std::uint8_t>(255 - i % 256);
    p.blue = 7;
    p.sigma_mm = 0.01f * i;
    points.push_back(p);
  }
  for (bool binary : {true, false}) {
    const std::string path = (dir / (binary ? "b.ply" : "a.ply")).string();
    io::WritePlyFile(path, points, binary);
    const auto back = io::ReadPlyFile(path);
    ASSERT_EQ(back.size(), points.size());
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_EQ(back[i].x, points[i].x);
      EXPECT_EQ(back[i].z, points[i].z);
      EXPECT_EQ(back[i].green, points[i].green);
      EXPECT_EQ(back[i].sigma_mm, points[i].sigma_mm);
    }
  }
  // A folder that does not exist: an error, and nothing written.
  EXPECT_ANY_THROW(io::WritePlyFile((dir / "missing" / "c.ply").string(), points));
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
  EXPECT_THROW(io::ReadPlyFile((dir / "nope.ply").string()), io::InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace omni::stereo
