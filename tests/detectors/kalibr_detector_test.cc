// Kalibr AprilGrid detection (kalibr_detector.h through DetectTagCorners) on POV-Ray renders of
// the misaligned sample rig, grids at 0.5-2 m, tilted and rolled, against the exact truth
// (ComputeTruth): found fraction of the truly visible corners, zero wrong ids, corner error per
// ring, and the raw-image saddle refinement against the corners merely mapped from the views.
// OMNI_KALIBR_DUMP=<folder> writes the raw image and every view as PNG for inspection.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <tuple>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/synthetic/image_effects.h"
#include "calib/synthetic/pov_scene.h"
#include "calib/synthetic/scene.h"
#include "calib/synthetic/tag_texture.h"
#include "detectors/apriltag_detector.h"
#include "detectors/kalibr_detector.h"
#include "detectors/views.h"
#include "model/io/model_file.h"

#include "tests/detectors/render_window.h"

namespace omni::detectors {
namespace {

namespace fs = std::filesystem;

TargetSpec KalibrGrid(int rows, int cols, double tag_mm, int first_id) {
  TargetSpec s;
  s.type = TargetType::kKalibrAprilGrid;
  s.rows = rows;
  s.cols = cols;
  s.tag_size_mm = tag_mm;
  s.spacing = 0.3;
  s.first_id = first_id;
  return s;
}

struct Rendered {
  RigParams rig;
  synthetic::Scene scene;
  std::vector<synthetic::CornerTruth> truth;
  cv::Mat image;
};

// Four grids at 0.5, 0.9, 1.4 and 2 m, each turned about its centre (tilt about the vertical,
// roll about its normal), rendered only in windows around each grid's image in each ring.
Rendered RenderKalibrGrids() {
  Rendered r;
  r.rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                            "/sample_configs/big_rig_misaligned.yaml");
  const RigModel model(r.rig);
  // Tags of about 2 px per bit in the inner ring (half the outer ring's resolution), grids low
  // enough to fit in the rings' elevation range.
  r.scene.targets = {KalibrGrid(1, 3, 80, 0), KalibrGrid(1, 4, 140, 10), KalibrGrid(1, 3, 220, 30),
                     KalibrGrid(2, 2, 260, 50)};
  const IdealModel ideal = r.rig.Ideal();
  const double z_mid = 0.5 * (ideal.c1 + ideal.d - ideal.c2);
  synthetic::SceneImage image{"kalibr", {}};
  const double azimuth[4] = {0.5, 2.1, 3.7, 5.3}, range[4] = {500, 900, 1400, 2000};
  const double tilt[4] = {0.5, -0.3, 0.2, 0.0}, roll[4] = {0.3, -0.4, 0.5, 0.15};
  for (int t = 0; t < 4; ++t) {
    const Eigen::Vector3d centre(range[t] * std::cos(azimuth[t]), range[t] * std::sin(azimuth[t]),
                                 z_mid);
    synthetic::Placement p = synthetic::PlaceFacingAxis(r.scene.targets[t], t, centre);
    const Eigen::Vector3d centre_in_target =
        p.cam_from_target_rotation.transpose() * (centre - p.cam_from_target_translation);
    p.cam_from_target_rotation =
        p.cam_from_target_rotation *
        Eigen::Matrix3d(Eigen::AngleAxisd(tilt[t], Eigen::Vector3d::UnitY()) *
                        Eigen::AngleAxisd(roll[t], Eigen::Vector3d::UnitZ()));
    p.cam_from_target_translation = centre - p.cam_from_target_rotation * centre_in_target;
    image.placements.push_back(p);
  }
  r.scene.images.push_back(image);
  r.truth = synthetic::ComputeTruth(model, r.scene, image);
  const std::string dir = fs::temp_directory_path() / "omni_kalibr_detect";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string error;
  EXPECT_TRUE(synthetic::WriteTagTextures(r.scene.targets, dir, &error)) << error;
  cv::Mat pinhole(r.rig.image_height, r.rig.image_width, CV_8UC3, cv::Scalar::all(0));
  const std::string pov = synthetic::PovSceneText(r.rig, synthetic::ContentOf(r.scene, image));
  for (int t = 0; t < 4; ++t) {
    for (int m = 0; m < 2; ++m) {
      cv::Rect box;
      double side = 0;  // a tag's side in pixels, for the margin (corner squares, quiet zone)
      for (const auto& c : r.truth) {
        if (c.target != t || !c.pixel[m]) continue;
        const cv::Rect one(static_cast<int>(c.pixel[m]->x()), static_cast<int>(c.pixel[m]->y()), 1, 1);
        box = box.empty() ? one : (box | one);
        for (const auto& d : r.truth) {
          if (d.target == t && d.pixel[m] && d.id == (c.id ^ 1) && c.id % 4 == 0) {
            side = std::max(side, (*d.pixel[m] - *c.pixel[m]).norm());
          }
        }
      }
      if (box.empty()) continue;
      const int margin = 10 + static_cast<int>(0.6 * side);
      box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
            cv::Rect(0, 0, r.rig.image_width, r.rig.image_height);
      const std::string png = dir + "/w" + std::to_string(t) + std::to_string(m) + ".png";
      EXPECT_TRUE(testing::RenderWindowInto(pov, box, testing::WindowOptions(r.rig, box), png,
                                            &pinhole, &error))
          << error;
    }
  }
  r.image = synthetic::ApplyDistortion(pinhole, r.rig);
  return r;
}

TEST(KalibrDetector, GridsAtHalfToTwoMetresInBothRingsMatchTheTruth) {
  const Rendered r = RenderKalibrGrids();
  const RigModel model(r.rig);
  std::vector<RingView> views = MakeRingViews(model);

  // Detection time on one core: resampling the views + detection + refinement.
  cv::setNumThreads(1);
  std::vector<TagCornerDetection> found;
  constexpr int kRuns = 3;
  const auto t0 = std::chrono::steady_clock::now();
  for (int run = 0; run < kRuns; ++run) {
    RenderViews(r.image, &views);
    found = DetectTagCorners(r.image, views, model, r.scene.targets);
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() / kRuns;
  cv::setNumThreads(-1);
  if (const char* dump = std::getenv("OMNI_KALIBR_DUMP")) {
    fs::create_directories(dump);
    cv::imwrite(std::string(dump) + "/raw.png", r.image);
    for (std::size_t v = 0; v < views.size(); ++v) {
      cv::imwrite(std::string(dump) + "/view" + std::to_string(v) + ".png", views[v].image);
      cv::imwrite(std::string(dump) + "/mask" + std::to_string(v) + ".png",
                  KalibrTagMask(views[v].image, KalibrDetectorOptions()));
    }
  }

  std::map<std::tuple<int, int, int>, Eigen::Vector2d> truth;  // (target, id, mirror) -> pixel
  for (const auto& c : r.truth) {
    for (int m = 0; m < 2; ++m) {
      if (c.pixel[m]) truth[{c.target, c.id, m + 1}] = *c.pixel[m];
    }
  }
  struct Stats {
    int visible = 0, found = 0, wrong = 0;
    double sum = 0, max = 0, mapped_sum = 0, mapped_max = 0;
  } stats[2];
  std::map<std::pair<int, int>, std::pair<int, int>> per_target;  // (target, mirror) -> found/visible
  for (const auto& [key, px] : truth) {
    ++stats[std::get<2>(key) - 1].visible;
    ++per_target[{std::get<0>(key), std::get<2>(key)}].second;
  }
  for (const TagCornerDetection& d : found) {
    const auto& o = d.observation;
    Stats& s = stats[o.mirror - 1];
    const auto it = truth.find({o.target, o.id, o.mirror});
    if (it == truth.end() || (it->second - o.pixel).norm() > 2.0) {
      ++s.wrong;
      continue;
    }
    const double e = (it->second - o.pixel).norm(), e_mapped = (it->second - d.mapped).norm();
    ++s.found;
    ++per_target[{o.target, o.mirror}].first;
    s.sum += e;
    s.max = std::max(s.max, e);
    s.mapped_sum += e_mapped;
    s.mapped_max = std::max(s.mapped_max, e_mapped);
  }
  std::printf("kalibr_aprilgrid: %zu corners, %.1f ms per %dx%d image on one core (views + "
              "detection + refinement)\n", found.size(), ms, r.image.cols, r.image.rows);
  for (const auto& [key, counts] : per_target) {
    // Mean tag side in raw pixels (bottom edges k = 0 -> 1) from the truth.
    double side = 0;
    int sides = 0;
    for (const auto& [corner, px] : truth) {
      const auto next = truth.find({std::get<0>(corner), std::get<1>(corner) + 1, std::get<2>(corner)});
      if (std::get<0>(corner) != key.first || std::get<2>(corner) != key.second ||
          std::get<1>(corner) % 4 != 0 || next == truth.end()) {
        continue;
      }
      side += (next->second - px).norm();
      ++sides;
    }
    std::printf("  target %d (%.0f mm tags, %.1f px in raw) mirror %d: %d/%d corners\n", key.first,
                r.scene.targets[key.first].tag_size_mm, side / std::max(1, sides), key.second,
                counts.first, counts.second);
  }
  for (int m = 0; m < 2; ++m) {
    const Stats& s = stats[m];
    const int n = std::max(1, s.found);
    std::printf("mirror %d: %d/%d visible corners found, %d wrong; error mean %.3f px max %.3f px "
                "(as reported); mapped from the view: mean %.3f px max %.3f px\n",
                m + 1, s.found, s.visible, s.wrong, s.sum / n, s.max, s.mapped_sum / n,
                s.mapped_max);
    EXPECT_EQ(s.wrong, 0);
    EXPECT_GE(s.found, 0.95 * s.visible);
    EXPECT_LE(s.sum / n, 0.1);
    EXPECT_LE(s.max, 0.4);
  }
}

}  // namespace
}  // namespace omni::detectors
