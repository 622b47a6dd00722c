// `export` of a single-mirror rig (RigKind::kSingle): one ring in every format, against the
// unified model's closed form (central_mirror.h). A perspective lens at an aligned hyperboloid's
// far focus is central, so
//  - kalibr / basalt: the one ring's fitted unified (double sphere) model projects scene points
//    as the closed form does, to 5e-4 px (the fit stops at an RMS of 1e-5 px; xi and gamma
//    themselves trade with radtan's k1, k2 over the ring's elevations, so they are not compared),
//    and reprojects the non-central model's own rays as closely; the files name one camera;
//  - rays: shape (1, H, W, 6), every ray passes through the mirror's near focus;
//  - panorama_maps: ring 1's maps alone, viewpoints_mm (1, 3) the near focus.
#include <gtest/gtest.h>

#include <cmath>

#include "exports/central_fit.h"
#include "exports/central_models.h"
#include "exports/model_export.h"
#include "exports/panorama_maps.h"
#include "exports/ray_table.h"
#include "model/central_mirror.h"
#include "model/rig_params.h"

namespace omni::exports {
namespace {

struct SingleCamera {
  CentralMirror central;
  RigParams rig;
  Eigen::Vector3d focus;
};

SingleCamera Hyperbolic() {
  SingleCamera s;
  s.central.mirror = Conic<double>{20.0, -2.2};
  s.central.focal_px = 300;
  const double below = s.central.CameraBelowVertexMm();
  // A small image keeps the ray table and the fits quick.
  s.rig = MakeSingleRig(s.central.mirror, LensKind::kPerspective, below, 30, 5,
                        Pinhole<double>{300, 300, 240, 180, 0}, 480, 360);
  double near = 0;
  s.central.mirror.NearFocus(&near);
  s.focus = Eigen::Vector3d(0, 0, below + near);
  return s;
}

TEST(SingleRigExports, CentralFitsAreTheUnifiedModel) {
  const SingleCamera s = Hyperbolic();
  const UnifiedParameters unified = *UnifiedOf(s.central);
  const RigModel model(s.rig);
  for (CentralModel kind : {CentralModel::kUnified, CentralModel::kDoubleSphere}) {
    const std::vector<CentralRing> rings = FitCentral(model, kind, {});
    ASSERT_EQ(rings.size(), 1u);
    const CentralRing& ring = rings[0];
    EXPECT_EQ(ring.mirror, Mirror::kOne);
    for (const CentralResidual& r : ring.residuals) {
      EXPECT_GT(r.pixels, 1000);
      EXPECT_EQ(r.not_projected, 0);
      EXPECT_LT(r.max_px, 5e-4) << CentralModelName(kind) << " at " << r.distance_mm << " mm";
    }
    // The virtual camera sits at the near focus.
    EXPECT_LT((ring.cam_from_rig.Inverse().translation - s.focus).norm(), 1e-4);
    // Scene points around the mirror, projected by the fitted ring and by the closed form.
    double worst = 0;
    int compared = 0;
    for (int i = 0; i < 400; ++i) {
      const double azimuth = 0.0157 * i * 7, elevation = -1.2 + 0.003 * i, range = 300 + 20 * i;
      const Eigen::Vector3d point =
          s.focus + range * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                            std::cos(elevation) * std::sin(azimuth),
                                            std::sin(elevation));
      const Eigen::Vector3d v = (point - s.focus).normalized();
      const Eigen::Vector2d expected(240 + unified.gamma * v.x() / (unified.xi - v.z()),
                                     180 + unified.gamma * v.y() / (unified.xi - v.z()));
      if (!model.Project(point, Mirror::kOne)) continue;  // outside the ring
      const Eigen::Vector3d p = ring.cam_from_rig * point;
      Eigen::Vector2d pixel;
      const bool ok = kind == CentralModel::kUnified
                          ? ProjectUnified(ring.intrinsics.data(), p.data(), pixel.data())
                          : ProjectDoubleSphere(ring.intrinsics.data(), p.data(), pixel.data());
      ASSERT_TRUE(ok);
      worst = std::max(worst, (pixel - expected).norm());
      ++compared;
    }
    EXPECT_GT(compared, 100);
    EXPECT_LT(worst, 5e-4) << CentralModelName(kind) << ": px from the closed form";
  }
  ExportOptions options;
  options.model = "single.yaml";
  options.allow_uncalibrated = true;
  for (const char* format : {"kalibr", "basalt"}) {
    options.format = format;
    options.out = std::string("x.") + (options.format == "kalibr" ? "yaml" : "json");
    const ModelExport e = ExportModel(s.rig, options);
    ASSERT_TRUE(e.rings && e.rings->size() == 1) << format;
    EXPECT_EQ(e.bytes.find("cam1"), std::string::npos) << e.bytes;
    EXPECT_EQ(e.bytes.find("two rings"), std::string::npos) << e.bytes;
    EXPECT_NE(e.bytes.find("single-mirror camera single.yaml"), std::string::npos) << e.bytes;
    EXPECT_EQ(e.summary.find("ring 2"), std::string::npos) << e.summary;
  }
}

TEST(SingleRigExports, RaysAndPanoramaMapsHaveOneRing) {
  const SingleCamera s = Hyperbolic();
  const RigModel model(s.rig);
  const NpyArray rays = RayTable(model, ReferenceBody::kCam, DType::kFloat64);
  ASSERT_EQ(rays.shape, (std::vector<int64_t>{1, 360, 480, 6}));
  int seen = 0;
  double worst = 0;
  for (size_t i = 0; i < rays.f64.size(); i += 6) {
    if (std::isnan(rays.f64[i])) continue;
    ++seen;
    const Eigen::Vector3d o(rays.f64[i], rays.f64[i + 1], rays.f64[i + 2]);
    const Eigen::Vector3d d(rays.f64[i + 3], rays.f64[i + 4], rays.f64[i + 5]);
    const Eigen::Vector3d w = s.focus - o;
    worst = std::max(worst, (w - w.dot(d) * d).norm());
  }
  EXPECT_GT(seen, 50000);
  EXPECT_LT(worst, 1e-9) << "mm from the near focus";

  stereo::PanoramaOptions options;
  options.width = 256;
  const std::vector<NpyArray> maps = PanoramaMaps(model, options);
  std::vector<std::string> names;
  for (const NpyArray& a : maps) names.push_back(a.name);
  EXPECT_EQ(names, (std::vector<std::string>{"ring1_map_x", "ring1_map_y", "elevation_rad",
                                             "azimuth_rad", "viewpoints_mm", "cam_from_cylinder",
                                             "radius_mm"}));
  const NpyArray& viewpoints = maps[4];
  ASSERT_EQ(viewpoints.shape, (std::vector<int64_t>{1, 3}));
  EXPECT_LT((Eigen::Vector3d(viewpoints.f64[0], viewpoints.f64[1], viewpoints.f64[2]) - s.focus)
                .norm(),
            1e-12);
}

}  // namespace
}  // namespace omni::exports
