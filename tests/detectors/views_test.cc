// Ring layout and ring views against the model's exact ray tracing (RigModel::Unproject), an
// independent code path from the forward projection the views are built with.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "detectors/common/ring_layout.h"
#include "detectors/common/views.h"
#include "io/model_file.h"
#include "model/rig_params.h"

namespace omni::detectors {
namespace {

RigModel MisalignedRig() {
  return RigModel(io::ReadModelFile(OMNISTEREO_SOURCE_DIR "/sample_configs/big_rig_misaligned.yaml"));
}

// Every pixel the layout gives to a ring back-projects through that ring's mirror, and every
// pixel that back-projects through a mirror is labelled with it, except within 1.5 px of a
// boundary (the boundaries are sampled every 0.5 degree).
TEST(RingLayoutTest, LabelsAgreeWithRayTracing) {
  const RigModel model = MisalignedRig();
  const RingLayout layout = ComputeRingLayout(model);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, layout.width - 1), v(0, layout.height - 1);
  int checked = 0, ring_pixels[3] = {0, 0, 0};
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    const RingLabel label = layout.LabelAt(pixel);
    if (label != RingLabel::kMirror1 && label != RingLabel::kMirror2) continue;
    const Mirror mirror = label == RingLabel::kMirror1 ? Mirror::kOne : Mirror::kTwo;
    if (layout.DepthInRing(pixel, mirror) < 1.5) continue;
    const auto ray = model.Unproject(pixel);
    ASSERT_TRUE(ray.has_value()) << pixel.transpose();
    EXPECT_EQ(ray->mirror, mirror) << pixel.transpose();
    ++checked;
    ++ring_pixels[MirrorIndex(mirror)];
  }
  EXPECT_GT(ring_pixels[1], 2000);
  EXPECT_GT(ring_pixels[2], 500);
  // The converse: rays through a mirror come from pixels labelled with it.
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    const auto ray = model.Unproject(pixel);
    if (!ray) continue;
    if (layout.DepthInRing(pixel, ray->mirror) < 1.5) continue;
    const RingLabel expected = ray->mirror == Mirror::kOne ? RingLabel::kMirror1 : RingLabel::kMirror2;
    EXPECT_EQ(layout.LabelAt(pixel), expected) << pixel.transpose();
  }
  // The rims and the reflex edge of the big rig at fx ~1450 px (see docs/design.md, Conventions): about 405 px
  // for mirror 1's rim and 214 px for the reflex disc, within a few pixels of misalignment.
  EXPECT_NEAR(layout.mirror1_rim.RadiusAt(0.3), 405, 8);
  EXPECT_NEAR(layout.reflex_edge.RadiusAt(-2.0), 214, 6);
  EXPECT_GT(checked, 2500);
}

class ViewsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    model_ = new RigModel(MisalignedRig());
    views_ = new std::vector<RingView>(MakeRingViews(*model_));
  }
  static void TearDownTestSuite() {
    delete views_;
    delete model_;
  }
  static RigModel* model_;
  static std::vector<RingView>* views_;
};
RigModel* ViewsTest::model_ = nullptr;
std::vector<RingView>* ViewsTest::views_ = nullptr;

// The interpolated map agrees with the exact projection (what corners are mapped back with)
// and the back-projection of the raw pixel lands on the view pixel again.
TEST_F(ViewsTest, MapsAgreeWithModel) {
  ASSERT_EQ(views_->size(), 16u);
  std::mt19937 rng(5);
  double worst_map = 0, worst_round_trip = 0;
  int n = 0;
  for (const RingView& view : *views_) {
    std::uniform_real_distribution<double> x(0, view.width - 1), y(0, view.height - 1);
    int valid = 0;
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector2d p(x(rng), y(rng));
      const auto exact = view.ViewToRawExact(*model_, p);
      const auto interp = view.ViewToRaw(p);
      if (!exact || !interp) continue;
      ++valid;
      worst_map = std::max(worst_map, (*exact - *interp).norm());
      const auto back = view.RawToView(*model_, *exact);
      ASSERT_TRUE(back.has_value());
      worst_round_trip = std::max(worst_round_trip, (*back - p).norm());
      ++n;
    }
    EXPECT_GT(valid, 50) << "view of mirror " << MirrorIndex(view.mirror) << " at azimuth "
                         << view.azimuth;
  }
  EXPECT_LT(worst_map, 0.05);
  EXPECT_LT(worst_round_trip, 1e-3);
  EXPECT_GT(n, 2000);
}

// Views are not mirrored: a 3D "L" (origin, a point to its right seen from the rig, a point
// above it) keeps its handedness in the views of both rings, and up is up.
TEST_F(ViewsTest, ViewsAreNotMirrored) {
  for (const RingView& view : *views_) {
    const double el = view.elevation;
    const Eigen::Vector3d dir(std::cos(el) * std::cos(view.azimuth), std::cos(el) * std::sin(view.azimuth),
                              std::sin(el));
    const Eigen::Vector3d centre = view.viewpoint_in_cam + 1500.0 * dir;
    const Eigen::Vector3d right = dir.cross(Eigen::Vector3d::UnitZ()).normalized();
    auto to_view = [&](const Eigen::Vector3d& p) {
      const auto raw = model_->Project(p, view.mirror);
      EXPECT_TRUE(raw.has_value());
      const auto px = raw ? view.RawToView(*model_, *raw) : std::nullopt;
      EXPECT_TRUE(px.has_value());
      return px.value_or(Eigen::Vector2d::Zero());
    };
    const Eigen::Vector2d o = to_view(centre), r = to_view(centre + 50 * right),
                          up = to_view(centre + 50 * Eigen::Vector3d::UnitZ());
    EXPECT_GT(r.x() - o.x(), 5) << "mirror " << MirrorIndex(view.mirror);
    EXPECT_LT(up.y() - o.y(), -5) << "mirror " << MirrorIndex(view.mirror);
  }
}

}  // namespace
}  // namespace omni::detectors

namespace omni::detectors {
namespace {

// A wide single mirror (the sample paraboloid behind a telecentric lens: its ring spans ~90 deg
// of elevation, more than a view's 80): every direction the ring sees lies inside some view, so
// a board anywhere in the field can be found (a view cut to 80 deg about the horizon had lost
// the boards nearest the mirror's centre). The oracle: the model's exact back-projection of
// pixels across the ring, each ray's direction tested against every view's pinhole.
TEST(WideSingleMirrorViews, CoverTheWholeField) {
  // 8 px per mm: the 30 mm rim at 240 px; the hole 2 mm.
  const RigModel model(MakeSingleRig(Conic<double>{24.0, -1.0}, LensKind::kTelecentric, 80.0, 30.0,
                                     2.0, Pinhole<double>{8, 8, 319.5, 255.5, 0}, 640, 512));
  const std::vector<RingView> views = MakeRingViews(model);
  ASSERT_EQ(views.size(), 8u);
  double lo = 1e9, hi = -1e9;
  int rays = 0, outside = 0;
  for (double radius = 1; radius < 256; radius += 3) {
    for (int k = 0; k < 36; ++k) {
      const double t = 2 * M_PI * k / 36;
      const auto ray = model.Unproject(Eigen::Vector2d(319.5 + radius * std::cos(t),
                                                       255.5 + radius * std::sin(t)));
      if (!ray) continue;
      ++rays;
      const Eigen::Vector3d d = ray->ray.direction.normalized();
      lo = std::min(lo, std::asin(d.z()));
      hi = std::max(hi, std::asin(d.z()));
      bool inside = false;
      for (const RingView& view : views) {
        const Eigen::Vector3d in_view = view.cam_from_view.transpose() * d;
        if (in_view.z() <= 0) continue;
        const double u = view.cx + view.f * in_view.x() / in_view.z();
        const double v = view.cy + view.f * in_view.y() / in_view.z();
        inside = inside || (u >= 0 && v >= 0 && u <= view.width - 1 && v <= view.height - 1);
      }
      outside += !inside;
    }
  }
  ASSERT_GT(rays, 500);
  EXPECT_GT((hi - lo) * 180 / M_PI, 85) << "the field is not wider than a view's cap";
  EXPECT_EQ(outside, 0) << "of " << rays << " rays, elevations " << lo * 180 / M_PI << ".."
                        << hi * 180 / M_PI << " deg";
}

}  // namespace
}  // namespace omni::detectors
