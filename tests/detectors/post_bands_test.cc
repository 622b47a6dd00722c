// Posts as bands of a ring's grid (detectors/lips/post_bands.h) on drawn grids: a textured room
// (blocks of random grey) or a plain one (one grey with noise), posts of unequal widths at uneven
// azimuths, dark or light, each bin the coverage-weighted mean of post and room (edges between
// bins). The oracle is the drawn edges.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "detectors/lips/post_bands.h"

namespace omni::detectors {
namespace {

struct DrawnPost {
  double left, right;  // bins (bin b spans [b, b + 1))
  float grey;
};

constexpr int kBins = 1440, kElevations = 32;  // 0.25 deg bins

// The room: textured (blocks of grey 30-230, 1 deg by two elevations: a room's texture changes
// along a ring's elevations as across its azimuths) or plain (grey 115); sensor noise sigma 1.5.
RingGrid DrawRing(bool textured, const std::vector<DrawnPost>& posts, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> block(30, 230);
  std::normal_distribution<float> noise(0, 1.5f);
  std::vector<float> blocks((kBins / 4 + 1) * (kElevations / 2 + 1));
  for (float& b : blocks) b = block(rng);
  RingGrid grid;
  grid.bins = kBins;
  grid.elevations = kElevations;
  grid.levels.resize(kBins * kElevations);
  for (int b = 0; b < kBins; ++b) {
    for (int j = 0; j < kElevations; ++j) {
      float level = textured ? blocks[(b / 4) * (kElevations / 2 + 1) + j / 2] : 115.0f;
      for (const DrawnPost& p : posts) {
        const double cover = std::clamp(std::min(b + 1.0, p.right) - std::max(b + 0.0, p.left), 0.0, 1.0);
        level = static_cast<float>(cover * p.grey + (1 - cover) * level);
      }
      grid.levels[b * kElevations + j] = std::clamp(level + noise(rng), 0.0f, 255.0f);
    }
  }
  return grid;
}

// The bands' widths of post_finder's options at 0.25 deg: 1.5-12 deg, sides 0.75 deg out.
constexpr int kMinWidth = 6, kMaxWidth = 48, kGap = 3;
constexpr double kMinScore = 4;

std::vector<Band> Find(const std::vector<RingGrid>& photos, int most) {
  std::vector<BandScores> scores;
  for (const RingGrid& g : photos) scores.push_back(ScoreBands(g, kMinWidth, kMaxWidth, kGap, 1.0));
  return BestBands(MedianScores(scores), kGap, kMinScore, most);
}

// Each drawn post found once, its edges placed within `tolerance` bins in every photo.
void ExpectFound(const std::vector<RingGrid>& photos, const std::vector<DrawnPost>& posts, double tolerance) {
  const std::vector<Band> bands = Find(photos, static_cast<int>(posts.size()) + 2);
  ASSERT_EQ(bands.size(), posts.size());
  for (const DrawnPost& p : posts) {
    const Band* match = nullptr;
    for (const Band& band : bands) {
      if (std::abs(band.lo + 0.5 * band.width - 0.5 * (p.left + p.right)) < 2) match = &band;
    }
    ASSERT_NE(match, nullptr) << "post at " << p.left << "-" << p.right << " not found";
    for (const RingGrid& g : photos) {
      const BandEdges edges = PlaceBandEdges(g, *match, kGap);
      ASSERT_TRUE(edges.ok);
      EXPECT_NEAR(edges.left, p.left, tolerance);
      EXPECT_NEAR(edges.right, p.right, tolerance);
    }
  }
}

// Three posts of 3, 4.5 and 6 mm at 41.5 mm (4.1, 6.2, 8.3 deg: 16.6, 24.8, 33.2 bins), dark,
// light and mid-grey, at uneven azimuths (one across 0 deg).
const std::vector<DrawnPost> kPosts = {{1421.3, 1437.9, 40}, {300.6, 325.4, 225}, {905.2, 938.4, 90}};

// Edges within 0.5 bins (0.125 deg) against texture: the room beyond an edge is not the room in
// the edge's bin; 0.25 bins against a plain wall.
TEST(PostBands, FindsPostsOfUnequalWidthsInATexturedRoom) {
  ExpectFound({DrawRing(true, kPosts, 1), DrawRing(true, kPosts, 2), DrawRing(true, kPosts, 3)}, kPosts, 0.5);
}

TEST(PostBands, FindsPostsInAPlainRoom) {
  ExpectFound({DrawRing(false, kPosts, 4), DrawRing(false, kPosts, 5)}, kPosts, 0.25);
}

TEST(PostBands, FindsNothingWithoutPosts) {
  for (bool textured : {true, false}) {
    const std::vector<Band> bands = Find({DrawRing(textured, {}, 6), DrawRing(textured, {}, 7), DrawRing(textured, {}, 8)}, 3);
    EXPECT_TRUE(bands.empty()) << (textured ? "textured" : "plain") << ": a band at " << bands.front().lo
                               << " scoring " << bands.front().score;
  }
}

// A room's plain patch in one photo is not a post: the median over photos keeps what all show.
TEST(PostBands, APlainPatchInOnePhotoIsNoPost) {
  const std::vector<DrawnPost> patch = {{600, 620, 128}};
  const std::vector<Band> bands = Find({DrawRing(true, patch, 9), DrawRing(true, {}, 10), DrawRing(true, {}, 11)}, 3);
  EXPECT_TRUE(bands.empty());
}

// The other ring's view of a post, a few degrees off (a model not yet calibrated).
TEST(PostBands, BestBandNearFindsTheOtherRingsPost) {
  const std::vector<DrawnPost> shifted = {{320.6, 345.4, 225}};
  std::vector<BandScores> scores;
  for (unsigned seed : {12u, 13u}) scores.push_back(ScoreBands(DrawRing(true, shifted, seed), kMinWidth, kMaxWidth, kGap, 1.0));
  const BandScores median = MedianScores(scores);
  const Band near = BestBandNear(median, 313.0, 32, 12, 40);
  EXPECT_GT(near.score, kMinScore);
  EXPECT_NEAR(near.lo + 0.5 * near.width, 333.0, 2.0);
  EXPECT_LT(BestBandNear(median, 313.0, 8, 12, 40).score, kMinScore);  // out of reach
}

}  // namespace
}  // namespace omni::detectors
