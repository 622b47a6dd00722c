// The mount's posts found in photos (detectors/lips/post_finder.h) on POV-Ray renders of the paper's
// prototype (big_rig_prototype.yaml: three 3 mm posts at 41.5 mm, azimuths 90 / 210 / 330 deg in
// mirror 1's body) in a textured room, at 640x480: the oracle is the mount the renderer drew.
// The same room without the posts finds none.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/detect_image.h"
#include "detectors/lips/lip_detector.h"
#include "detectors/lips/lip_intrinsics.h"
#include "detectors/lips/post_finder.h"
#include "io/model_file.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"
#include "tests/temp_dir.h"

namespace omni::detectors {
namespace {

RigParams Sample(const std::string& name) {
  return synthetic::RigAtImageSize(
      io::ReadModelFile(std::string(OMNISTEREO_SOURCE_DIR) + "/sample_configs/" + name), 640, 480);
}

// Two colour images of the room (its texture shifted between them, as a scene changes between
// photos).
std::vector<cv::Mat> Grey(const std::vector<cv::Mat>& colour) {
  std::vector<cv::Mat> out(colour.size());
  for (size_t i = 0; i < colour.size(); ++i) cv::cvtColor(colour[i], out[i], cv::COLOR_BGR2GRAY);
  return out;
}

std::vector<cv::Mat> RenderRoom(const RigParams& rig, const std::string& tag, bool plain = false,
                                double post_grey = 0.25) {
  const std::string dir = testing::UniqueTempDir("omni_posts_" + tag);
  std::filesystem::create_directories(dir);
  std::vector<cv::Mat> greys;
  for (int k = 0; k < 2; ++k) {
    synthetic::SceneContent content;
    content.room = true;
    content.room_plain = plain;
    content.post_grey = post_grey;
    content.room_texture_offset_mm = Eigen::Vector3d(0, 700.0 * k, 300.0 * k);
    synthetic::RenderOptions options;
    options.width = rig.image_width;
    options.height = rig.image_height;
    const std::string png = dir + "/" + std::to_string(k) + ".png";
    std::string error;
    if (!synthetic::RenderScene(synthetic::PovSceneText(rig, content), png, options, &error)) {
      ADD_FAILURE() << error;
      return {};
    }
    greys.push_back(cv::imread(png, cv::IMREAD_COLOR));
  }
  std::filesystem::remove_all(dir);
  return greys;
}

double AngleBetween(double a, double b) { return std::abs(std::remainder(a - b, 2 * M_PI)); }

TEST(PostFinder, FindsThePrototypesPostsFromTheDesign) {
  const RigParams prototype = Sample("big_rig_prototype.yaml");
  ASSERT_TRUE(prototype.mount.present);
  const std::vector<cv::Mat> photos = RenderRoom(prototype, "with");
  ASSERT_EQ(photos.size(), 2u);
  // Looked for with the design (coaxial, no mount) whose f and principal point are fitted to the
  // lips, as `init` writes it, and with the true model.
  RigParams design = Sample("big_rig_ideal.yaml");
  std::vector<LipEdgeObservation> edges;
  for (const cv::Mat& photo : photos) {
    const auto found = DetectLips(LipInput(photo), RigModel(design));
    edges.insert(edges.end(), found.begin(), found.end());
  }
  const auto lips = InitialIntrinsicsFromLips(edges, RigModel(design));
  ASSERT_TRUE(lips);
  design.camera[kFx] = design.camera[kFy] = lips->f;
  design.camera[kCx] = lips->cx;
  design.camera[kCy] = lips->cy;
  for (const RigParams* model : {static_cast<const RigParams*>(&design), &prototype}) {
    const std::vector<FoundPost> posts = FindPosts(Grey(photos), RigModel(*model), 3);
    for (const FoundPost& post : posts) {
      double nearest = 1e9;
      for (double truth : prototype.mount.azimuths) nearest = std::min(nearest, AngleBetween(post.azimuth, truth));
      std::printf("%s: post at %.2f deg (%.2f deg from the drawn one), width %.2f deg, score %.3f\n",
                  model == &design ? "design" : "truth", post.azimuth * 180 / M_PI,
                  nearest * 180 / M_PI, post.width * 180 / M_PI, post.score);
      // The drawn post: 3 mm at 41.5 mm spans 4.3 deg seen from the axis (its near face).
      EXPECT_LT(nearest * 180 / M_PI, 1.0);
      EXPECT_NEAR(post.width * 180 / M_PI, 4.3, 0.5);
      EXPECT_NEAR(PostSideFromBand(post.width, 41.5), 3.0, 0.35);
    }
    ASSERT_EQ(posts.size(), 3u);
    EXPECT_GT(AngleBetween(posts[0].azimuth, posts[1].azimuth), 1.0);  // three distinct posts
    EXPECT_GT(AngleBetween(posts[1].azimuth, posts[2].azimuth), 1.0);
    EXPECT_GT(AngleBetween(posts[0].azimuth, posts[2].azimuth), 1.0);
  }
  // A model whose mount is turned 5 deg from the photos': each photo says by how much; the true
  // mount: nothing to say.
  RigParams turned = prototype;
  for (double& a : turned.mount.azimuths) a += 5 * M_PI / 180;
  for (const cv::Mat& grey : Grey(photos)) {
    const std::optional<double> turn = MountTurnInPhoto(grey, RigModel(turned));
    ASSERT_TRUE(turn);
    std::printf("photo of the mount turned by -5 deg: %+.2f deg\n", *turn * 180 / M_PI);
    EXPECT_NEAR(*turn * 180 / M_PI, -5.0, 0.5);
    EXPECT_FALSE(MountTurnInPhoto(grey, RigModel(prototype)));
  }
  // A model that lacks one of the photo's posts, and one with a post the photo does not show
  // (half-way between two real ones): each photo names them; the true mount: nothing.
  RigParams lacking = prototype;
  const double dropped = lacking.mount.azimuths.back();
  lacking.mount.azimuths.pop_back();
  if (!lacking.mount.widths.empty()) lacking.mount.widths.pop_back();
  RigParams extra = prototype;
  const double ghost = 0.5 * (prototype.mount.azimuths[0] + prototype.mount.azimuths[1]);
  extra.mount.azimuths.push_back(ghost);
  if (!extra.mount.widths.empty()) extra.mount.widths.push_back(extra.mount.widths.back());
  for (const cv::Mat& grey : Grey(photos)) {
    const MountInPhoto truth = CompareMountWithPhoto(grey, RigModel(prototype));
    EXPECT_FALSE(truth.turn);
    EXPECT_TRUE(truth.unexpected.empty());
    EXPECT_TRUE(truth.unseen.empty());
    const MountInPhoto without = CompareMountWithPhoto(grey, RigModel(lacking));
    ASSERT_EQ(without.unexpected.size(), 1u);
    EXPECT_LT(AngleBetween(without.unexpected[0].azimuth, dropped) * 180 / M_PI, 1.0);
    EXPECT_TRUE(without.unseen.empty());
    const MountInPhoto with_ghost = CompareMountWithPhoto(grey, RigModel(extra));
    EXPECT_TRUE(with_ghost.unexpected.empty());
    ASSERT_EQ(with_ghost.unseen.size(), 1u);
    EXPECT_EQ(with_ghost.unseen[0], 3);
  }
  // The same rig and room without its mount: nothing is taken for a post.
  RigParams bare = prototype;
  bare.mount = Mount();
  const std::vector<FoundPost> none = FindPosts(Grey(RenderRoom(bare, "without")), RigModel(design), 3);
  for (const FoundPost& post : none) {
    std::printf("without posts: found at %.2f deg, score %.3f\n", post.azimuth * 180 / M_PI, post.score);
  }
  EXPECT_TRUE(none.empty());
}

// Four light posts of unequal widths (3-6 mm) at uneven azimuths in a plain room (no texture to
// tell them by: their contrast with the walls does), found from the design fitted to the lips.
TEST(PostFinder, FindsLightPostsOfUnequalWidthsInAPlainRoom) {
  RigParams rig = Sample("big_rig_prototype.yaml");
  rig.mount.azimuths = {10 * M_PI / 180, 100 * M_PI / 180, 170 * M_PI / 180, 275 * M_PI / 180};
  rig.mount.widths = {3.0, 6.0, 4.0, 5.0};
  const std::vector<cv::Mat> photos = RenderRoom(rig, "light", true, 0.8);
  ASSERT_EQ(photos.size(), 2u);
  RigParams design = Sample("big_rig_ideal.yaml");
  std::vector<LipEdgeObservation> edges;
  for (const cv::Mat& photo : photos) {
    const auto found = DetectLips(LipInput(photo), RigModel(design));
    edges.insert(edges.end(), found.begin(), found.end());
  }
  const auto lips = InitialIntrinsicsFromLips(edges, RigModel(design));
  ASSERT_TRUE(lips);
  design.camera[kFx] = design.camera[kFy] = lips->f;
  design.camera[kCx] = lips->cx;
  design.camera[kCy] = lips->cy;
  const PostSearch search = SearchPosts(Grey(photos), RigModel(design), 4);
  ASSERT_EQ(search.found.size(), 4u);
  EXPECT_EQ(search.photos, 2);
  for (size_t i = 0; i < rig.mount.azimuths.size(); ++i) {
    const FoundPost* match = nullptr;
    for (const FoundPost& post : search.found) {
      if (AngleBetween(post.azimuth, rig.mount.azimuths[i]) < 3 * M_PI / 180) match = &post;
    }
    ASSERT_NE(match, nullptr) << "post " << i;
    const double side = PostSideFromBand(match->width, rig.mount.radius);
    std::printf("post %zu: %.2f deg off, side %.2f mm (drawn %.1f), sigma %.2f deg\n", i,
                AngleBetween(match->azimuth, rig.mount.azimuths[i]) * 180 / M_PI, side, rig.mount.widths[i],
                match->sigma_azimuth * 180 / M_PI);
    EXPECT_LT(AngleBetween(match->azimuth, rig.mount.azimuths[i]) * 180 / M_PI, 1.0);
    EXPECT_NEAR(side, rig.mount.widths[i], 0.5);
  }
  // A fifth post asked for: none scores; what was searched and the four found are said.
  const PostSearch five = SearchPosts(Grey(photos), RigModel(design), 5);
  EXPECT_EQ(five.found.size(), 4u);
  EXPECT_EQ(five.searched, "0-360 deg");
}

}  // namespace
}  // namespace omni::detectors
