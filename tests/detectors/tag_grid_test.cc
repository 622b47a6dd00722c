// Tag grids (plain tag36h11 and Kalibr AprilGrid) through DetectImage on POV-Ray renders of the
// misaligned sample rig at 1280x960, against the exact truth (ComputeTruth): per grid and ring
// the fraction of truly visible corners found, wrong ids (none allowed) and the corner error.
// Only windows around each grid in each ring are rendered (whole frames are slow).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <tuple>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "detectors/detect_image.h"
#include "io/model_file.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "synthetic/tag_texture.h"
#include "tests/temp_dir.h"

#include "tests/render_window.h"

namespace omni::detectors {
namespace {

namespace fs = std::filesystem;

TargetSpec TagGrid(TargetType type, int rows, int cols, double tag_mm, int first_id) {
  TargetSpec s;
  s.type = type;
  s.rows = rows;
  s.cols = cols;
  s.tag_size_mm = tag_mm;
  s.spacing = 0.3;
  s.first_id = first_id;
  return s;
}

struct GridResult {
  int visible = 0, found = 0, wrong = 0;
  std::vector<double> errors;
  double Mean() const {
    double m = 0;
    for (double e : errors) m += e / errors.size();
    return m;
  }
  double Max() const { return errors.empty() ? 0 : *std::max_element(errors.begin(), errors.end()); }
};

// Renders `image` of `scene` in windows around each target's corners in each ring (padded by
// `pad_sides` of the target's largest tag side there), distortion and noise as `omnistereo
// render`, runs DetectImage and scores it per (target, mirror).
std::map<std::pair<int, int>, GridResult> RenderAndDetect(const RigParams& rig,
                                                          const synthetic::Scene& scene,
                                                          const synthetic::SceneImage& image,
                                                          const std::string& dir) {
  const RigModel model(rig);
  const auto truth = synthetic::ComputeTruth(model, scene, image);
  fs::create_directories(dir);
  std::string texture_error;
  EXPECT_TRUE(synthetic::WriteTagTextures(scene.targets, dir, &texture_error)) << texture_error;
  const std::string pov = synthetic::PovSceneText(rig, synthetic::ContentOf(scene, image));
  cv::Mat pinhole(rig.image_height, rig.image_width, CV_8UC3, cv::Scalar::all(0));
  std::vector<cv::Rect> boxes;
  for (std::size_t t = 0; t < scene.targets.size(); ++t) {
    for (int m = 0; m < 2; ++m) {
      std::map<int, Eigen::Vector2d> by_id;
      for (const auto& c : truth) {
        if (c.target == static_cast<int>(t) && c.pixel[m]) by_id[c.id] = *c.pixel[m];
      }
      double side = 0;
      for (const auto& [id, px] : by_id) {
        const auto next = by_id.find(id + 1);
        if (next != by_id.end() && id % 4 != 3) side = std::max(side, (next->second - px).norm());
      }
      const int pad = static_cast<int>(side) + 8;
      cv::Rect box;
      for (const auto& [id, px] : by_id) {
        const cv::Rect one(static_cast<int>(px.x()) - pad, static_cast<int>(px.y()) - pad,
                           2 * pad + 1, 2 * pad + 1);
        box = box.empty() ? one : (box | one);
      }
      box &= cv::Rect(0, 0, rig.image_width, rig.image_height);
      if (!box.empty()) boxes.push_back(box);
    }
  }
  for (std::size_t b = 0; b < boxes.size(); ++b) {
    const cv::Rect& box = boxes[b];
    synthetic::RenderOptions options = testing::WindowOptions(rig, box);
    options.antialias = scene.antialias;
    options.threads = 1;
    const std::string png = dir + "/w" + std::to_string(b) + ".png";
    std::string error;
    EXPECT_TRUE(testing::RenderWindowInto(pov, box, options, png, &pinhole, &error)) << error;
  }
  cv::Mat raw = synthetic::ApplyDistortion(pinhole, rig);
  synthetic::AddNoise(&raw, scene.noise_sigma, scene.noise_seed);
  cv::imwrite(dir + "/" + image.name + ".png", raw);  // to look at when the test fails

  DetectorContext ctx(rig, scene.targets, /*use_lips=*/false);
  const ImageObservations det = DetectImage(raw, &ctx);
  std::map<std::pair<int, int>, GridResult> results;
  std::map<std::tuple<int, int, int>, Eigen::Vector2d> by_key;
  for (const auto& c : truth) {
    for (int m = 1; m <= 2; ++m) {
      if (!c.pixel[m - 1]) continue;
      by_key[{c.target, c.id, m}] = *c.pixel[m - 1];
      ++results[{c.target, m}].visible;
    }
  }
  for (const auto& o : det.corners) {
    // Wrong: the nearest true corner in the ring is another one.
    const TrueCornerMatch match = NearestTrueCorner(truth, o.mirror, o.pixel);
    const double e = match.distance_px;
    const TruthCorner* nearest = match.corner;
    GridResult& r = results[{o.target, MirrorIndex(o.mirror)}];
    if (!nearest || nearest->target != o.target || nearest->id != o.id || e > 1.0) {
      ++r.wrong;
      ADD_FAILURE() << "target " << o.target << " id " << o.id << " ring " << MirrorIndex(o.mirror)
                    << ": the nearest truth is target " << (nearest ? nearest->target : -1)
                    << " id " << (nearest ? nearest->id : -1) << " at " << e << " px";
      continue;
    }
    ++r.found;
    r.errors.push_back(e);
  }
  return results;
}

// Tag grids of several angular sizes at 1 m (tag side 0.05 to 0.12 rad: the inner ring's raw
// tag is about 155 px/rad * that, the outer ring's about 270 px/rad): what each detector needs.
TEST(TagGrids, AngularSizeLimitAt1m) {
  const RigParams rig = io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) +
                                          "/sample_configs/big_rig_misaligned.yaml");
  synthetic::Scene scene;
  scene.noise_sigma = 1.0;
  scene.noise_seed = 5;
  const double sizes[] = {50, 70, 90, 120};
  for (int i = 0; i < 4; ++i) {
    scene.targets.push_back(TagGrid(TargetType::kAprilTagGrid, 2, 3, sizes[i], 6 * i));
    scene.targets.push_back(TagGrid(TargetType::kKalibrAprilGrid, 2, 3, sizes[i], 100 + 6 * i));
  }
  const IdealModel ideal = rig.Ideal();
  const double z_mid = 0.5 * (ideal.c1 + ideal.d - ideal.c2);
  synthetic::SceneImage image{"sizes", {}};
  for (std::size_t t = 0; t < scene.targets.size(); ++t) {
    const double az = 2 * M_PI * (t + 0.3) / scene.targets.size();
    image.placements.push_back(synthetic::PlaceFacingAxis(
        scene.targets[t], static_cast<int>(t),
        Eigen::Vector3d(1000 * std::cos(az), 1000 * std::sin(az), z_mid)));
  }
  scene.images.push_back(image);
  const auto results =
      RenderAndDetect(rig, scene, image, omni::testing::UniqueTempDir("omni_tag_sizes"));
  for (const auto& [key, r] : results) {
    const TargetSpec& s = scene.targets[key.first];
    std::printf("%s %2.0f mm ring %d: %d of %d found, mean %.3f px, max %.3f px, %d wrong\n",
                s.type == TargetType::kAprilTagGrid ? "plain " : "kalibr", s.tag_size_mm,
                key.second, r.found, r.visible, r.Mean(), r.Max(), r.wrong);
    EXPECT_EQ(r.wrong, 0);
    // Measured (noise 1, at 1446b24): plain grids from 70 mm (inner ring ~11 px tags, 1.4 px per
    // bit) all found in both rings at 0.04-0.10 px mean (none at 50 mm in the inner ring);
    // Kalibr grids all found in the outer ring at 0.03-0.04 px, and in the inner ring from 70 mm
    // at 0.02-0.03 px (max 0.11; read by their expected blurred pattern, or guided from the outer
    // ring), 19 of 24 at 50 mm (0.28 px: ~0.8 raw px per bit). A lost tag would drop 4 corners; a
    // corner taken from the view unrefined or off by a bit would be 0.5+ px.
    const bool plain = s.type == TargetType::kAprilTagGrid;
    if ((plain && s.tag_size_mm >= 70) ||
        (!plain && s.tag_size_mm >= (key.second == 1 ? 50 : 70))) {
      EXPECT_GE(r.found, 0.95 * r.visible) << s.tag_size_mm << " mm, ring " << key.second;
      EXPECT_LT(r.Mean(), plain ? 0.15 : 0.1) << s.tag_size_mm << " mm, ring " << key.second;
      EXPECT_LT(r.Max(), 0.35) << s.tag_size_mm << " mm, ring " << key.second;
    }
  }
}

}  // namespace
}  // namespace omni::detectors
