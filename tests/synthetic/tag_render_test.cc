// Tag-grid sheets rendered by POV-Ray through the misaligned big rig
// (sample_configs/big_rig_misaligned.yaml): the tag edges at each truth corner lie where the model
// projects them (the 50% crossing of the rendered intensity across each of the corner's two edges,
// measured in pixels), and every data bit large enough to see has the texture's colour, so the
// image map is neither shifted, flipped nor turned, in either ring.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/model_file.h"
#include "model/rig_model.h"
#include "synthetic/image_effects.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "synthetic/tag_texture.h"
#include "tests/render_window.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

double Bilinear(const cv::Mat& grey, const Eigen::Vector2d& px) {
  const int u = static_cast<int>(std::floor(px.x())), v = static_cast<int>(std::floor(px.y()));
  const double a = px.x() - u, b = px.y() - v;
  auto at = [&](int vv, int uu) { return static_cast<double>(grey.at<float>(vv, uu)); };
  return (1 - b) * ((1 - a) * at(v, u) + a * at(v, u + 1)) +
         b * ((1 - a) * at(v + 1, u) + a * at(v + 1, u + 1));
}

struct Stats {
  int n = 0;
  double sum = 0, max = 0;
  void Add(double e) {
    ++n;
    sum += std::abs(e);
    max = std::max(max, std::abs(e));
  }
  double Mean() const { return n ? sum / n : 0.0; }
};

class TagRender : public ::testing::Test {
 protected:
  // Where the rendered edge through target point q (normal n_out, away from the tag) crosses
  // halfway between the tag's black and the white outside, in pixels along the projected normal
  // (positive: outwards). False if the profile leaves the image or the mirror's view.
  bool EdgeOffsetPx(const synthetic::Placement& p, const Eigen::Vector3d& q, const Eigen::Vector3d& n_out,
                    double bit_mm, Mirror mirror, double* offset_px) const {
    constexpr int kSamples = 33;
    const double half = 0.8 * bit_mm;
    std::vector<double> d(kSamples), value(kSamples);
    std::vector<Eigen::Vector2d> px(kSamples);
    for (int i = 0; i < kSamples; ++i) {
      d[i] = -half + 2 * half * i / (kSamples - 1);
      const auto pixel = model_->Project(
          p.cam_from_target_rotation * (q + d[i] * n_out) + p.cam_from_target_translation, mirror);
      if (!pixel || pixel->x() < 1 || pixel->y() < 1 || pixel->x() > grey_.cols - 2 ||
          pixel->y() > grey_.rows - 2) {
        return false;
      }
      px[i] = *pixel;
      value[i] = Bilinear(grey_, *pixel);
    }
    const double px_per_mm = (px[kSamples / 2 + 1] - px[kSamples / 2 - 1]).norm() /
                             (d[kSamples / 2 + 1] - d[kSamples / 2 - 1]);
    if (px_per_mm * bit_mm < 2.0) return false;  // edge blur would span the whole profile
    double inside = 0, outside = 0;
    int n_in = 0, n_out_samples = 0;
    for (int i = 0; i < kSamples; ++i) {
      if (d[i] < -0.5 * bit_mm) inside += value[i], ++n_in;
      if (d[i] > 0.5 * bit_mm) outside += value[i], ++n_out_samples;
    }
    inside /= n_in;
    outside /= n_out_samples;
    if (outside - inside < 0.5) return false;  // not a black/white edge at all
    const double level = 0.5 * (inside + outside);
    for (int i = 0; i + 1 < kSamples; ++i) {
      if ((value[i] - level) * (value[i + 1] - level) <= 0 && value[i + 1] != value[i]) {
        const double t = (level - value[i]) / (value[i + 1] - value[i]);
        *offset_px = (d[i] + t * (d[i + 1] - d[i])) * px_per_mm;
        return true;
      }
    }
    *offset_px = 1e9;  // no crossing: the edge is not there
    return true;
  }

  std::unique_ptr<RigModel> model_;
  cv::Mat grey_;  // rendered, distorted, 0..1
};

TEST_F(TagRender, TruthCornersLieOnRenderedTagEdgesThroughTheMisalignedRig) {
  const RigParams rig =
      io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
  model_ = std::make_unique<RigModel>(rig);
  synthetic::Scene scene;
  TargetSpec plain;
  plain.type = TargetType::kAprilTagGrid;
  plain.rows = 2;
  plain.cols = 3;
  plain.tag_size_mm = 80;
  plain.spacing = 0.3;
  plain.first_id = 0;
  TargetSpec kalibr = plain;
  kalibr.type = TargetType::kKalibrAprilGrid;
  kalibr.first_id = 20;
  scene.targets = {plain, kalibr};
  // Facing the axis at 600 mm, at the height between the two foci (inside both mirrors' views).
  const IdealModel ideal = rig.Ideal();
  const double z_mid = 0.5 * (ideal.c1 + ideal.d - ideal.c2);
  synthetic::SceneImage image{"tags", {}};
  const double azimuths[2] = {1.4, 3.6};
  for (int t = 0; t < 2; ++t) {
    image.placements.push_back(synthetic::PlaceFacingAxis(
        scene.targets[t], t,
        Eigen::Vector3d(600 * std::cos(azimuths[t]), 600 * std::sin(azimuths[t]), z_mid)));
  }
  scene.images.push_back(image);
  const auto truth = synthetic::ComputeTruth(*model_, scene, image);

  // Render only the windows around each target's corners (both rings): fast, and the rest of
  // the image stays black.
  const std::string dir = fs::temp_directory_path() / "omni_tag_render";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string error;
  ASSERT_TRUE(synthetic::WriteTagTextures(scene.targets, dir, &error)) << error;
  const auto t0 = std::chrono::steady_clock::now();
  cv::Mat pinhole(rig.image_height, rig.image_width, CV_8UC3, cv::Scalar::all(0));
  for (int t = 0; t < 2; ++t) {
    cv::Rect box;
    for (const auto& c : truth) {
      for (const auto& px : c.pixel) {
        if (c.target != t || !px) continue;
        const cv::Rect one(static_cast<int>(px->x()) - 12, static_cast<int>(px->y()) - 12, 25, 25);
        box = box.empty() ? one : (box | one);
      }
    }
    box &= cv::Rect(0, 0, rig.image_width, rig.image_height);
    ASSERT_FALSE(box.empty());
    const synthetic::RenderOptions options = omni::testing::WindowOptions(rig, box);
    const std::string png = dir + "/window" + std::to_string(t) + ".png";
    ASSERT_TRUE(synthetic::RenderScene(synthetic::PovSceneText(rig, synthetic::ContentOf(scene, image)),
                                       png, options, &error)) << error;
    cv::imread(png, cv::IMREAD_COLOR)(box).copyTo(pinhole(box));
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  cv::cvtColor(synthetic::ApplyDistortion(pinhole, rig), grey_, cv::COLOR_BGR2GRAY);
  grey_.convertTo(grey_, CV_32F, 1.0 / 255);

  // Edges: at each visible corner, both tag edges half a bit away from the corner.
  Stats edges[2];
  int missing = 0;
  for (const auto& c : truth) {
    const TargetSpec& spec = scene.targets[c.target];
    const synthetic::Placement& p = image.placements[c.placement];
    const double bit = spec.tag_size_mm / synthetic::TagBitsAcross(spec);
    const Eigen::Vector3d corner = CornerInTarget(spec, c.id);
    // The tag's centre: the mean of its four corners.
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) centre += 0.25 * CornerInTarget(spec, 4 * (c.id / 4) + k);
    const double sx = centre.x() > corner.x() ? 1 : -1, sy = centre.y() > corner.y() ? 1 : -1;
    for (int m = 0; m < 2; ++m) {
      if (!c.pixel[m]) continue;
      const Mirror mirror = m == 0 ? Mirror::kOne : Mirror::kTwo;
      ASSERT_LT((*model_->Project(c.point_in_cam, mirror) - *c.pixel[m]).norm(), 1e-9);
      double along_x = 0, along_y = 0;  // the edge running along x (normal -sy y), along y
      const bool ok_x = EdgeOffsetPx(p, corner + Eigen::Vector3d(0.5 * bit * sx, 0, 0),
                                     Eigen::Vector3d(0, -sy, 0), bit, mirror, &along_x);
      const bool ok_y = EdgeOffsetPx(p, corner + Eigen::Vector3d(0, 0.5 * bit * sy, 0),
                                     Eigen::Vector3d(-sx, 0, 0), bit, mirror, &along_y);
      if (ok_x) edges[m].Add(along_x);
      if (ok_y) edges[m].Add(along_y);
      missing += !ok_x + !ok_y;
    }
  }
  // Bits: the rendered colour at each data bit's centre against the texture.
  int bits_checked = 0, bits_wrong = 0;
  for (size_t pi = 0; pi < image.placements.size(); ++pi) {
    const synthetic::Placement& p = image.placements[pi];
    const TargetSpec& spec = scene.targets[p.target];
    const auto texture = synthetic::MakeTagTexture(spec);
    const Eigen::Vector4d sheet = SheetBounds(spec);
    const int bits = synthetic::TagBitsAcross(spec), border = bits == 10 ? 2 : 1;
    const double bit = spec.tag_size_mm / bits;
    for (int id : CornerIds(spec)) {
      if (id % 4 != 3) continue;  // one pass per tag, from its top-left corner
      const Eigen::Vector3d top_left = CornerInTarget(spec, id);
      for (int by = border; by < bits - border; ++by) {
        for (int bx = border; bx < bits - border; ++bx) {
          const Eigen::Vector3d x = top_left + Eigen::Vector3d((bx + 0.5) * bit, (by + 0.5) * bit, 0);
          const int tu = static_cast<int>((x.x() - sheet[0]) / texture.mm_per_pixel);
          const int tv = static_cast<int>((x.y() - sheet[1]) / texture.mm_per_pixel);
          const bool white = texture.image.at<uint8_t>(tv, tu) > 127;
          for (Mirror mirror : {Mirror::kOne, Mirror::kTwo}) {
            const Eigen::Vector3d x_cam = p.cam_from_target_rotation * x + p.cam_from_target_translation;
            const auto a = model_->Project(x_cam, mirror);
            const auto b = model_->Project(
                p.cam_from_target_rotation * (x + Eigen::Vector3d(bit, 0, 0)) +
                    p.cam_from_target_translation, mirror);
            if (!a || !b || (*a - *b).norm() < 3.0) continue;  // too small to read
            ++bits_checked;
            bits_wrong += (Bilinear(grey_, *a) > 0.5) != white;
          }
        }
      }
    }
  }
  std::printf("rendered 2 windows in %.1f s; edge offsets mirror 1: %d edges, mean %.3f px, max "
              "%.3f px; mirror 2: %d edges, mean %.3f px, max %.3f px; %d edges too small or "
              "outside; data bits %d/%d right\n", seconds, edges[0].n, edges[0].Mean(),
              edges[0].max, edges[1].n, edges[1].Mean(), edges[1].max, missing,
              bits_checked - bits_wrong, bits_checked);
  // 2 grids x 6 tags x 4 corners x 2 edges = 96 per ring if all visible.
  EXPECT_GE(edges[0].n, 80);
  EXPECT_GE(edges[1].n, 40);
  for (int m = 0; m < 2; ++m) {
    EXPECT_LT(edges[m].Mean(), 0.1) << "mirror " << m + 1;
    EXPECT_LT(edges[m].max, 0.3) << "mirror " << m + 1;
  }
  EXPECT_GE(bits_checked, 200);
  EXPECT_EQ(bits_wrong, 0);
}

}  // namespace
}  // namespace omni
