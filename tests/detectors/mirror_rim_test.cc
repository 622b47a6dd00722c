// The mirror rim finder (detectors/lips/mirror_rim.h) on drawn photos of a single-mirror camera
// whose rim is known exactly: a textured mirror image inside a circle, the dark housing outside,
// the camera's own dark reflection at the centre, a sleeve across part of the rim; area-sampled
// (4x4 per pixel), blurred, noisy and JPEG-compressed. The circle found against the drawn one.
#include "detectors/lips/mirror_rim.h"

#include <gtest/gtest.h>

#include "tests/detectors/drawn_rim.h"

namespace omni::detectors {
namespace {

using testing::Drawn;
using testing::Photo;

TEST(MirrorRim, FindsTheDrawnRimInOnePhotoAndInSeveral) {
  const Drawn d;
  const MirrorRim one = FindMirrorRim({Photo(d, 1)});
  ASSERT_TRUE(one.found) << one.why;
  EXPECT_NEAR(one.centre.x(), d.cx, 0.1);
  EXPECT_NEAR(one.centre.y(), d.cy, 0.1);
  EXPECT_NEAR(one.radius_px, d.r, 0.1);
  EXPECT_GT(one.coverage, 0.75);  // the sleeve hides ~10% of the rim
  EXPECT_LT(one.coverage, 0.95);
  const MirrorRim several = FindMirrorRim({Photo(d, 2), Photo(d, 3), Photo(d, 4)});
  ASSERT_TRUE(several.found) << several.why;
  EXPECT_NEAR(several.centre.x(), d.cx, 0.1);
  EXPECT_NEAR(several.centre.y(), d.cy, 0.1);
  EXPECT_NEAR(several.radius_px, d.r, 0.1);
}

// A mirror whose image is taller than the photo (a public hyperbolic-mirror set at 1024x768 shows
// its rim 452 px from the centre): the rays where the rim leaves the photo have no edge; their
// neighbours' sub-pixel step once read a level off the image and the fit came out NaN but "found".
TEST(MirrorRim, ARimLeavingThePhotoAtTopAndBottom) {
  Drawn d;
  d.width = 700;
  d.height = 480;
  d.cx = 351.4;
  d.cy = 238.7;
  d.r = 268.3;  // beyond the photo over about a third of its circle
  const MirrorRim rim = FindMirrorRim({Photo(d, 1), Photo(d, 2), Photo(d, 3)});
  ASSERT_TRUE(rim.found) << rim.why;
  EXPECT_NEAR(rim.centre.x(), d.cx, 0.15);
  EXPECT_NEAR(rim.centre.y(), d.cy, 0.15);
  EXPECT_NEAR(rim.radius_px, d.r, 0.15);
  EXPECT_LT(rim.coverage, 0.7);
}

TEST(MirrorRim, ADarkerMirrorIsFoundWithItsPolarity) {
  const Drawn d;
  cv::Mat inverted = 255 - Photo(d, 5);
  MirrorRimOptions options;
  options.inside_brighter = false;
  const MirrorRim rim = FindMirrorRim({inverted}, options);
  ASSERT_TRUE(rim.found) << rim.why;
  EXPECT_NEAR(rim.radius_px, d.r, 0.1);
}

TEST(MirrorRim, NoRimNoCircleAndBadOptionsNamed) {
  cv::Mat noise(480, 640, CV_8U);
  cv::randu(noise, 0, 255);
  const MirrorRim rim = FindMirrorRim({noise});
  EXPECT_FALSE(rim.found);
  EXPECT_FALSE(rim.why.empty());
  MirrorRimOptions options;
  options.rays = 10;
  EXPECT_EQ(options.Check(), "rays: expected at least 36");
  EXPECT_THROW(FindMirrorRim({noise}, options), std::invalid_argument);
  EXPECT_THROW(FindMirrorRim({noise, cv::Mat(10, 10, CV_8U)}), std::invalid_argument);
}

}  // namespace
}  // namespace omni::detectors
