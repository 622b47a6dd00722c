// The single-mirror start (detectors/single_mirror_start.h): the rim's conic against the central
// cameras' closed forms and against a traced reflection; every mirror kind and lens from a found
// rim, the model written, read back and its rim projected where the photos show it (the scale's
// independent check); drawn photos through the rim finder; the diameter check and bad input.
#include "detectors/single_mirror_start.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "io/model_file.h"
#include "model/central_mirror.h"
#include "model/conic_sheet.h"
#include "model/lip.h"
#include "model/rig_model.h"
#include "tests/detectors/drawn_rim.h"

namespace omni::detectors {
namespace {

MirrorRim Rim(double cx, double cy, double radius) {
  MirrorRim rim;
  rim.found = true;
  rim.centre = {cx, cy};
  rim.radius_px = radius;
  rim.rms_px = 0.2;
  rim.coverage = 0.9;
  rim.edge_points = 600;
  return rim;
}

// The model written and read back: its rim's image (the direct view of the circle r_sys at the
// rim's height, lip.h) about the principal point at every azimuth; the worst distance from
// rim_px.
double WorstRimRadiusError(const RigParams& rig, const Eigen::Vector2d& centre, double rim_px) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("single_start_" + std::to_string(::getpid()) + ".yaml")).string();
  io::WriteModelFile(path, rig);
  const RigModel model(io::ReadModelFile(path));
  std::filesystem::remove(path);
  double worst = 0;
  for (int i = 0; i < 36; ++i) {
    const auto pixel = ProjectLipPoint(model, LipPath::kDirect, LipCircle::kOuter, i * M_PI / 18);
    if (!pixel) return 1e9;
    worst = std::max(worst, std::abs((*pixel - centre).norm() - rim_px));
  }
  return worst;
}

// The angle from the axis of the ray a lens at the origin (telecentric: looking along +z) sends
// to the rim, reflected by the conic (traced with ConicSheet's normal).
double ReflectedRimAngle(const RigParams& rig) {
  const ConicSheet<double> sheet{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK],
                                 rig.vertex_z};
  const Eigen::Vector3d p(rig.r_sys, 0, sheet.Z(rig.r_sys, 0));
  const Eigen::Vector3d in =
      rig.lens == LensKind::kTelecentric ? Eigen::Vector3d::UnitZ() : p.normalized();
  const Eigen::Vector3d n = sheet.Normal(p);
  const Eigen::Vector3d out = in - 2 * in.dot(n) * n;
  return std::acos(out.z()) * 180 / M_PI;
}

TEST(SingleMirrorStart, RimConicMatchesTheCentralCameras) {
  const double r = 30;
  // Telecentric over a paraboloid: the rim in the focus's plane, R = r; a sphere R = r sqrt(2).
  EXPECT_NEAR(RimConic(r, -1, 0)->conic.R, r, 1e-12);
  EXPECT_NEAR(RimConic(r, -1, 0)->rim_sag, r / 2, 1e-12);
  EXPECT_NEAR(RimConic(r, 0, 0)->conic.R, r * std::sqrt(2.0), 1e-12);
  // A hyperboloid with the camera at its far focus: R = r and the vertex R / (e - 1) up.
  for (double e : {1.2, std::sqrt(2.0), 2.5}) {
    const double alpha = std::atan((e * e - 1) / (2 * e));
    const auto rim = RimConic(r, -e * e, alpha);
    ASSERT_TRUE(rim);
    EXPECT_NEAR(rim->conic.R, r, 1e-9);
    const CentralMirror central{rim->conic, LensKind::kPerspective, 1000, 0};
    EXPECT_NEAR(r / std::tan(alpha) - rim->rim_sag, central.CameraBelowVertexMm(), 1e-9);
  }
  // A hyperboloid's slope stays below 1 / sqrt(-1 - K): K = -9 never reaches the rim's 0.74.
  EXPECT_FALSE(RimConic(r, -9, 0.3));
}

struct Case {
  MirrorKnowledge mirror;
  LensKind lens;
  double camera_distance, focal_px, magnification;
};

TEST(SingleMirrorStart, EveryKindProjectsItsRimWhereThePhotosShowIt) {
  const MirrorRim rim = Rim(641.5, 521.2, 353.0);
  const Case cases[] = {
      {MirrorKnowledge::kParabolic, LensKind::kTelecentric, 0, 0, 0},
      {MirrorKnowledge::kParabolic, LensKind::kTelecentric, 80, 0, 353.0 / 30 * 1.02},
      {MirrorKnowledge::kSpherical, LensKind::kTelecentric, 0, 0, 0},
      {MirrorKnowledge::kUnknown, LensKind::kTelecentric, 0, 0, 0},
      {MirrorKnowledge::kHyperbolic, LensKind::kPerspective, 0, 0, 0},
      {MirrorKnowledge::kHyperbolic, LensKind::kPerspective, 60, 0, 0},
      {MirrorKnowledge::kHyperbolic, LensKind::kPerspective, 0, 700, 0},
      {MirrorKnowledge::kUnknown, LensKind::kPerspective, 0, 0, 0},
      {MirrorKnowledge::kParabolic, LensKind::kPerspective, 0, 0, 0},
      {MirrorKnowledge::kParabolic, LensKind::kPerspective, 150, 0, 0},
      {MirrorKnowledge::kParabolic, LensKind::kPerspective, 0, 1500, 0},
      {MirrorKnowledge::kSpherical, LensKind::kPerspective, 120, 0, 0},
      {MirrorKnowledge::kSpherical, LensKind::kPerspective, 0, 1200, 0},
  };
  for (const Case& c : cases) {
    SingleMirrorKnowledge know;
    know.mirror_diameter = 60;
    know.mirror = c.mirror;
    know.lens = c.lens;
    know.camera_distance = c.camera_distance;
    know.focal_px = c.focal_px;
    know.magnification = c.magnification;
    const std::string what = std::string(MirrorKnowledgeName(c.mirror)) + " " +
                             LensKindName(c.lens) + " d " + std::to_string(c.camera_distance) +
                             " f " + std::to_string(c.focal_px);
    std::string why;
    const auto start = SingleMirrorStartFromRim(rim, know, 1280, 1024, &why);
    ASSERT_TRUE(start) << what << ": " << why;
    const RigParams& rig = start->rig;
    EXPECT_TRUE(rig.Single());
    EXPECT_EQ(rig.lens, c.lens);
    EXPECT_EQ(rig.r_sys, 30);
    EXPECT_EQ(rig.camera[kCx], 641.5);
    EXPECT_EQ(rig.camera[kCy], 521.2);
    EXPECT_LT(WorstRimRadiusError(rig, rim.centre, rim.radius_px), 1.0) << what;
    EXPECT_NEAR(ReflectedRimAngle(rig), 90, 1e-6) << what;
    const double K = rig.mirror1_shape[kShapeK];
    switch (c.mirror) {
      case MirrorKnowledge::kParabolic: EXPECT_EQ(K, -1) << what; break;
      case MirrorKnowledge::kSpherical: EXPECT_EQ(K, 0) << what; break;
      case MirrorKnowledge::kHyperbolic: EXPECT_LT(K, -1) << what; break;
      case MirrorKnowledge::kUnknown: EXPECT_LE(K, -1) << what; break;
    }
    // What the builder gave is kept: the distance (perspective) and the focal length.
    if (c.lens == LensKind::kPerspective && c.camera_distance > 0) {
      EXPECT_NEAR(rig.vertex_z, c.camera_distance, 1e-6) << what;
    }
    if (c.focal_px > 0) {
      EXPECT_NEAR(rig.camera[kFx], c.focal_px, 1e-9) << what;
    }
    // A hyperboloid seen in perspective starts central: the lens at its far focus.
    if (c.lens == LensKind::kPerspective && K < -1) {
      const CentralMirror central{Conic<double>{rig.mirror1_shape[kShapeC], K}, c.lens, 0, 0};
      EXPECT_NEAR(rig.vertex_z, central.CameraBelowVertexMm(), 1e-9) << what;
    }
    // The shape is estimated (nobody measured R); a declared paraboloid or sphere keeps its K.
    EXPECT_EQ(start->estimate, (std::vector<std::string>{"camera", "distortion", "mirror1_shape",
                                                         "mirror1_pose"}));
    const bool declared =
        c.mirror == MirrorKnowledge::kParabolic || c.mirror == MirrorKnowledge::kSpherical;
    ASSERT_EQ(start->priors.size(), declared ? 1u : 0u) << what;
    EXPECT_FALSE(start->comments.empty());
  }
}

TEST(SingleMirrorStart, TheDiameterIsCheckedWhereTwoThingsAreKnown) {
  const MirrorRim rim = Rim(400, 300, 250);
  SingleMirrorKnowledge know;
  know.mirror_diameter = 50;
  std::string why;
  // Telecentric: 250 px over a 25 mm radius is 10 px per mm; 5% tolerance.
  know.lens = LensKind::kTelecentric;
  know.mirror = MirrorKnowledge::kParabolic;
  know.magnification = 10.4;
  EXPECT_TRUE(SingleMirrorStartFromRim(rim, know, 800, 600, &why)) << why;
  know.magnification = 10.6;
  EXPECT_FALSE(SingleMirrorStartFromRim(rim, know, 800, 600, &why));
  EXPECT_EQ(why.rfind("mirror_diameter: ", 0), 0u) << why;
  EXPECT_NE(why.find("tolerance 5%"), std::string::npos) << why;
  know.magnification = 10;
  know.mirror_diameter = 25;  // the radius given for the diameter
  EXPECT_FALSE(SingleMirrorStartFromRim(rim, know, 800, 600, &why));
  // Perspective: the focal length and the rim place the lens; the given distance within 30%.
  know = SingleMirrorKnowledge();
  know.mirror_diameter = 50;
  know.mirror = MirrorKnowledge::kHyperbolic;
  know.focal_px = 600;
  const auto placed = SingleMirrorStartFromRim(rim, know, 800, 600, &why);
  ASSERT_TRUE(placed) << why;
  const double d = placed->rig.vertex_z;
  for (double factor : {0.8, 1.2}) {
    know.camera_distance = d * factor;
    EXPECT_TRUE(SingleMirrorStartFromRim(rim, know, 800, 600, &why)) << why;
  }
  know.camera_distance = d;
  know.mirror_diameter = 5;  // in cm
  EXPECT_FALSE(SingleMirrorStartFromRim(rim, know, 800, 600, &why));
  EXPECT_EQ(why.rfind("mirror_diameter: ", 0), 0u) << why;
  // A paraboloid seen in perspective, placed by focal_px, checked against the distance.
  know.mirror_diameter = 50;
  know.mirror = MirrorKnowledge::kParabolic;
  know.camera_distance = 0;
  const auto parabolic = SingleMirrorStartFromRim(rim, know, 800, 600, &why);
  ASSERT_TRUE(parabolic) << why;
  know.camera_distance = parabolic->rig.vertex_z * 1.25;
  EXPECT_TRUE(SingleMirrorStartFromRim(rim, know, 800, 600, &why)) << why;
  know.camera_distance = parabolic->rig.vertex_z * 2;
  EXPECT_FALSE(SingleMirrorStartFromRim(rim, know, 800, 600, &why));
  EXPECT_EQ(why.rfind("mirror_diameter: ", 0), 0u) << why;
}

// A central camera's unified model (model/central_mirror.h UnifiedOf) and its rim's image radius
// give back its mirror, distance and lens exactly; the distance checks the diameter.
TEST(SingleMirrorStart, FromAUnifiedFitTheCentralCameraItself) {
  const Conic<double> hyperboloid{20.0, -2.2};
  const CentralMirror perspective{hyperboloid, LensKind::kPerspective, 800, 0};
  RigParams truth = MakeSingleRig(hyperboloid, LensKind::kPerspective,
                                  perspective.CameraBelowVertexMm(), 30, 5,
                                  Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960);
  const RigParams paraboloid_truth =
      MakeSingleRig(Conic<double>{16.0, -1.0}, LensKind::kTelecentric, 60, 30, 4,
                    Pinhole<double>{13.3, 13.3, 640, 512, 0}, 1280, 1024);
  const CentralMirror telecentric{Conic<double>{16.0, -1.0}, LensKind::kTelecentric, 0, 13.3};
  for (const auto& [rig, central] : {std::pair{truth, perspective},
                                     std::pair{paraboloid_truth, telecentric}}) {
    const auto unified = UnifiedOf(central);
    ASSERT_TRUE(unified);
    const auto pixel =
        ProjectLipPoint(RigModel(rig), LipPath::kDirect, LipCircle::kOuter, 0.3);
    ASSERT_TRUE(pixel);
    const MirrorRim rim = Rim(rig.camera[kCx], rig.camera[kCy],
                              (*pixel - Eigen::Vector2d(rig.camera[kCx], rig.camera[kCy])).norm());
    SingleMirrorKnowledge know;
    know.mirror_diameter = 60;
    know.lens = central.lens;
    know.unified_xi = unified->xi;
    know.unified_gamma = unified->gamma;
    std::string why;
    const auto start = SingleMirrorStartFromRim(rim, know, rig.image_width, rig.image_height, &why);
    ASSERT_TRUE(start) << why;
    EXPECT_NEAR(start->rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeC], 1e-9);
    EXPECT_NEAR(start->rig.mirror1_shape[kShapeK], rig.mirror1_shape[kShapeK], 1e-9);
    EXPECT_NEAR(start->rig.camera[kFx], rig.camera[kFx], 1e-9);
    if (central.lens == LensKind::kPerspective) {
      EXPECT_NEAR(start->rig.vertex_z, rig.vertex_z, 1e-9);
      know.camera_distance = 1.25 * rig.vertex_z;
      EXPECT_TRUE(SingleMirrorStartFromRim(rim, know, 1280, 960, &why)) << why;
      know.mirror_diameter = 30;  // the radius given: the lens placed at about half the distance
      EXPECT_FALSE(SingleMirrorStartFromRim(rim, know, 1280, 960, &why));
      EXPECT_EQ(why.rfind("mirror_diameter: ", 0), 0u) << why;
    }
    EXPECT_LT(WorstRimRadiusError(start->rig, rim.centre, rim.radius_px), 1.0);
  }
  SingleMirrorKnowledge know;
  know.mirror_diameter = 60;
  know.unified_xi = 0.9;
  EXPECT_EQ(know.Check().rfind("unified: ", 0), 0u);
  know.unified_gamma = 400;
  know.focal_px = 800;
  EXPECT_EQ(know.Check().rfind("focal_px: ", 0), 0u);
  know.focal_px = 0;
  know.mirror = MirrorKnowledge::kParabolic;  // perspective: no central paraboloid
  EXPECT_EQ(know.Check().rfind("unified: ", 0), 0u);
  know.mirror = MirrorKnowledge::kHyperbolic;
  know.unified_xi = 1.2;  // no hyperboloid
  std::string why;
  EXPECT_FALSE(SingleMirrorStartFromRim(Rim(640, 480, 400), know, 1280, 960, &why));
  EXPECT_EQ(why.rfind("unified: ", 0), 0u) << why;
}

TEST(SingleMirrorStart, BadKnowledgeIsNamed) {
  SingleMirrorKnowledge know;
  EXPECT_EQ(know.Check(), "");  // no diameter: the scale is nominal (below)
  know.mirror_diameter = -60;
  EXPECT_EQ(know.Check().rfind("mirror_diameter: ", 0), 0u);
  know.mirror_diameter = 60;
  EXPECT_EQ(know.Check(), "");
  know.lens = LensKind::kTelecentric;
  know.mirror = MirrorKnowledge::kHyperbolic;
  EXPECT_EQ(know.Check().rfind("lens: ", 0), 0u);
  know.mirror = MirrorKnowledge::kParabolic;
  know.focal_px = 800;
  EXPECT_EQ(know.Check().rfind("focal_px: ", 0), 0u);
  know = SingleMirrorKnowledge();
  know.mirror_diameter = 60;
  know.mirror = MirrorKnowledge::kSpherical;
  EXPECT_EQ(know.Check().rfind("camera_distance: ", 0), 0u);
  know.camera_distance = 100;
  EXPECT_EQ(know.Check(), "");
  know.magnification = 10;
  EXPECT_EQ(know.Check().rfind("magnification: ", 0), 0u);
  MirrorKnowledge kind;
  EXPECT_TRUE(ParseMirrorKnowledge("parabolic", &kind));
  EXPECT_EQ(kind, MirrorKnowledge::kParabolic);
  EXPECT_FALSE(ParseMirrorKnowledge("conic", &kind));
}

TEST(SingleMirrorStart, DrawnPhotosThroughTheRimFinder) {
  const testing::Drawn d;
  const std::vector<cv::Mat> photos = {testing::Photo(d, 1), testing::Photo(d, 2),
                                       testing::Photo(d, 3)};
  SingleMirrorKnowledge know;
  know.mirror_diameter = 40;
  know.lens = LensKind::kTelecentric;
  know.mirror = MirrorKnowledge::kParabolic;
  know.magnification = d.r / 20;
  std::string why;
  const auto start = SingleMirrorStartFromPhotos(photos, know, &why);
  ASSERT_TRUE(start) << why;
  EXPECT_NEAR(start->rim.radius_px, d.r, 0.1);
  EXPECT_EQ(start->rig.image_width, d.width);
  EXPECT_EQ(start->rig.image_height, d.height);
  EXPECT_LT(WorstRimRadiusError(start->rig, Eigen::Vector2d(d.cx, d.cy), d.r), 0.2);
  know.mirror_diameter = 44;  // 10% off the magnification
  EXPECT_FALSE(SingleMirrorStartFromPhotos(photos, know, &why));
  EXPECT_EQ(why.rfind("mirror_diameter: ", 0), 0u) << why;
  // No rim: the finder's reason.
  cv::Mat noise(480, 640, CV_8U);
  cv::randu(noise, 0, 255);
  know.mirror_diameter = 40;
  EXPECT_FALSE(SingleMirrorStartFromPhotos({noise}, know, &why));
  EXPECT_EQ(why.rfind("images: no mirror rim found in the 1 photos: ", 0), 0u) << why;
  EXPECT_GT(why.size(), std::string("images: no mirror rim found in the 1 photos: ").size());
}

// No diameter measured (the public sample sets come without one): the scale from what else is
// known, else a nominal rim, said to leave the absolute size open. Against the closed forms: a
// telecentric lens's magnification m gives the diameter 2 rho / m; a perspective lens's distance
// is kept and the rim still projects where the photos show it.
TEST(SingleMirrorStart, WithoutADiameterTheScaleComesFromWhatIsKnownOrIsNominal) {
  const MirrorRim rim = Rim(400, 300, 250);
  std::string why;
  auto said = [](const SingleMirrorStart& start, const std::string& text) {
    for (const std::string& line : start.lines) {
      if (line.find(text) != std::string::npos) return true;
    }
    return false;
  };
  SingleMirrorKnowledge know;
  know.mirror = MirrorKnowledge::kHyperbolic;
  const auto nominal = SingleMirrorStartFromRim(rim, know, 800, 600, &why);
  ASSERT_TRUE(nominal) << why;
  EXPECT_EQ(nominal->rig.r_sys, kNominalDiameterMm / 2);
  EXPECT_TRUE(said(*nominal, "absolute size is not determined"));
  EXPECT_LT(WorstRimRadiusError(nominal->rig, rim.centre, rim.radius_px), 1.0);

  know.lens = LensKind::kTelecentric;
  know.mirror = MirrorKnowledge::kParabolic;
  know.magnification = 10;  // 250 px over 10 px per mm: a 25 mm radius
  const auto telecentric = SingleMirrorStartFromRim(rim, know, 800, 600, &why);
  ASSERT_TRUE(telecentric) << why;
  EXPECT_NEAR(telecentric->rig.r_sys, 25, 1e-9);
  EXPECT_NEAR(telecentric->rig.camera[kFx], 10, 1e-9);
  EXPECT_FALSE(said(*telecentric, "not determined"));

  for (MirrorKnowledge mirror : {MirrorKnowledge::kHyperbolic, MirrorKnowledge::kParabolic,
                                 MirrorKnowledge::kSpherical}) {
    know = SingleMirrorKnowledge();
    know.mirror = mirror;
    know.camera_distance = 90;
    const auto placed = SingleMirrorStartFromRim(rim, know, 800, 600, &why);
    ASSERT_TRUE(placed) << MirrorKnowledgeName(mirror) << ": " << why;
    EXPECT_NEAR(placed->rig.vertex_z, 90, 1e-6) << MirrorKnowledgeName(mirror);
    EXPECT_LT(WorstRimRadiusError(placed->rig, rim.centre, rim.radius_px), 1.0);
    EXPECT_NEAR(ReflectedRimAngle(placed->rig), 90, 1e-6) << MirrorKnowledgeName(mirror);
    EXPECT_TRUE(said(*placed, "as rough as that distance"));
  }
  know.mirror_diameter = -1;
  EXPECT_EQ(know.Check().rfind("mirror_diameter: ", 0), 0u);
}

}  // namespace
}  // namespace omni::detectors
