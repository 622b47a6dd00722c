// The photos that would decide an undecided tolerance check (design/decide_photos.h), on the
// calibrated test model: the sigma it starts from is the check's own (the information matrix and
// the gradient carried right), more photos never raise it, a check in the camera-rotation valley
// gets no photos, a decided check none either.
#include "design/decide_photos.h"

#include <gtest/gtest.h>

#include <cmath>

#include "io/model_file.h"

namespace omni::design {
namespace {

RigParams Calibrated() {
  return io::ReadModelFile(std::string(OMNI_SAMPLE_DIR) + "/../tests/data/calibrated_big_rig.yaml");
}

TEST(DecidePhotos, StartsAtTheChecksSigmaAndPhotosOnlyLowerIt) {
  const RigParams rig = Calibrated();
  ToleranceSpec spec;
  spec.mirror[0].tilt_rad = 1e-4;  // in the valley (mirror1.rx ~ cy)
  spec.mirror[1].decentre_mm = 0.3;
  spec.reflex_dz_mm = 0.05;
  spec.mirror[0].axial_mm = 50;  // far beyond: PASS
  std::vector<ToleranceCheck> checks = CheckTolerances(rig, spec);
  // Make every check but the PASS one undecided at its own value +- a sigma.
  for (ToleranceCheck& c : checks) {
    if (c.verdict == Verdict::kPass) continue;
    c.limit = c.value + 1.5 * *c.sigma;
    c.verdict = Verdict::kUndecided;
  }
  DecidingPhotosOptions few;
  few.max_photos = 2;
  DecidingPhotosOptions many;
  many.max_photos = 8;
  const auto with_few = PhotosThatDecide(rig, checks, 2.0, few);
  const auto with_many = PhotosThatDecide(rig, checks, 2.0, many);
  ASSERT_EQ(with_few.size(), 3u);  // the PASS check has no entry
  for (size_t i = 0; i < with_few.size(); ++i) {
    const auto c = std::find_if(checks.begin(), checks.end(),
                                [&](const auto& x) { return x.name == with_few[i].check; });
    EXPECT_NEAR(with_few[i].sigma_now, *c->sigma, 1e-6 * *c->sigma) << c->name;
    EXPECT_NEAR(with_few[i].sigma_needed, 0.75 * *c->sigma, 1e-12) << c->name;
    if (with_few[i].in_valley) {
      EXPECT_EQ(c->name, "mirror1.tilt");
      EXPECT_TRUE(with_few[i].photos.empty());
      EXPECT_NE(with_few[i].Describe("deg", 1).find("camera-rotation valley"), std::string::npos);
      continue;
    }
    EXPECT_LE(with_few[i].photos.size(), 2u);
    EXPECT_LT(with_few[i].sigma_after, with_few[i].sigma_now) << c->name;
    EXPECT_LE(with_many[i].sigma_after, with_few[i].sigma_after + 1e-15) << c->name;
    for (const CandidatePhoto& p : with_many[i].photos) EXPECT_GT(p.corners[0] + p.corners[1], 6);
  }
}

}  // namespace
}  // namespace omni::design
