// Synthetic calibration sessions for the calibration tests: the misaligned big rig
// (sample_configs/big_rig_misaligned.yaml) as the truth, exact corner pixels from
// synthetic's ComputeTruth (the fast path, no rendering) plus Gaussian pixel noise, and the
// ideal design (sample_configs/big_rig_ideal.yaml) as the starting model.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <random>
#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "io/model_file.h"
#include "model/lip.h"
#include "model/observations.h"
#include "model/target.h"
#include "synthetic/scene.h"
#include "synthetic/scene_file.h"

#ifndef OMNI_SOURCE_DIR
#error "OMNI_SOURCE_DIR must name the source tree"
#endif

namespace omni::testing {

inline RigParams MisalignedRig() {
  return io::ReadModelFile(std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_misaligned.yaml");
}
// A misalignment parameter (mirror1.*, mirror2.*, reflex.*), as the acceptance checks name them.
// A mirror's profile terms (mirror1.sag_p1 ...) are its shape, not a misalignment.
inline bool IsMisalignment(const std::string& name) {
  if (name.find(".sag_") != std::string::npos) return false;
  return name.rfind("mirror1.", 0) == 0 || name.rfind("mirror2.", 0) == 0 ||
         name.rfind("reflex.", 0) == 0;
}
// RIG's ideal design at an image size: what a user starts from (sample_configs/big_rig_ideal.yaml's
// camera: every pose, the reflex plane and the distortion zero, the principal point at the image
// centre, fx = fy = 1450 px).
inline RigParams IdealDesignOf(const RigParams& rig, int width, int height) {
  RigParams ideal = rig;
  ideal.kind = ModelKind::kIdeal;
  ideal.camera = {1450.0, 1450.0, (width - 1) / 2.0, (height - 1) / 2.0, 0.0};
  ideal.distortion = {};
  ideal.mirror1_pose = {};
  ideal.mirror2_pose = {};
  ideal.reflex = {};
  ideal.calibration.reset();
  return ideal;
}
inline RigParams IdealRig() {
  return io::ReadModelFile(std::string(OMNI_SOURCE_DIR) + "/sample_configs/big_rig_ideal.yaml");
}

// The value in `rig` of the calibration parameter `name` (model/rig_parameters.h); NaN if there
// is none, which fails any comparison with it.
inline double TruthValue(const RigParams& rig, const std::string& name) {
  const double* value = ParameterOf(rig, name);
  return value ? *value : NAN;
}

struct SyntheticSession {
  synthetic::Scene scene;
  std::vector<TargetSpec> targets;  // the session's targets (chessboards)
  std::vector<std::vector<TruthCorner>> truth;  // per image
};

inline TargetSpec Chessboard(int rows, int cols, double square_mm) {
  return ChessboardSpec(rows, cols, square_mm);
}

// Random placements of chessboards around the rig (synthetic RandomPlacement).
inline SyntheticSession MakeSession(const RigParams& truth_rig,
                                    const synthetic::RandomPlacement& random,
                                    const std::vector<TargetSpec>& boards) {
  SyntheticSession s;
  const RigModel model(truth_rig);
  s.scene.targets = boards;
  std::string error;
  if (!synthetic::AddRandomImages(model, random, &s.scene, &error)) throw std::runtime_error(error);
  // Random scenes may show one board definition several times in an image; detections name a
  // target by its session index, so the k-th copy in an image becomes session target
  // board + k * boards.size() (identical physical boards).
  int copies = 1;
  for (const auto& image : s.scene.images) {
    std::vector<int> count(boards.size(), 0);
    for (const auto& p : image.placements) copies = std::max(copies, ++count[p.target]);
  }
  for (int k = 0; k < copies; ++k) s.targets.insert(s.targets.end(), boards.begin(), boards.end());
  for (const auto& image : s.scene.images) s.truth.push_back(synthetic::ComputeTruth(model, s.scene, image));
  return s;
}

// The session's detections: every visible corner with N(0, noise_px^2) added to u and v.
inline Observations NoisyDetections(const SyntheticSession& s, double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  Observations d;
  d.session = "synthetic";
  for (size_t i = 0; i < s.truth.size(); ++i) {
    ImageObservations image;
    image.file = s.scene.images[i].name + ".png";
    image.width = 1280;
    image.height = 960;
    const auto& placements = s.scene.images[i].placements;
    std::vector<int> session_target(placements.size());
    std::vector<int> count(s.scene.targets.size(), 0);
    for (size_t p = 0; p < placements.size(); ++p) {
      session_target[p] = placements[p].target +
                          static_cast<int>(s.scene.targets.size()) * count[placements[p].target]++;
    }
    for (const auto& c : s.truth[i]) {
      for (int m = 0; m < 2; ++m) {
        if (!c.pixel[m]) continue;
        CornerObservation o;
        o.target = session_target[c.placement];
        o.id = c.id;
        o.mirror = m == 0 ? Mirror::kOne : Mirror::kTwo;
        o.pixel = *c.pixel[m] + Eigen::Vector2d(noise(rng), noise(rng));
        image.corners.push_back(o);
      }
    }
    d.images.push_back(image);
  }
  return d;
}

// Lip edge points the detector would report (detectors/lips/lip_detector.h's rule, without an image):
// per azimuth, a coloured band's outer (inner) edge is the outermost (innermost) image of its
// lip's circles over the band's paths (blue: direct + via_mirror1; red: via_reflex +
// via_mirror2), kept where no other (circle, path) image lies within 1.5 px. Exact pixels from
// model/lip.h at the truth rig plus N(0, noise_px^2) per axis; `profiles` azimuths per circle.
// Added to every image of `detections` (each image sees the same lips, with its own noise).
inline void AddLipDetections(const RigParams& truth, double noise_px, unsigned seed,
                             Observations* detections, int profiles = 360) {
  const RigModel model(truth);
  const Eigen::Vector2d centre(truth.camera[kCx], truth.camera[kCy]);
  struct Image {
    LipPath path;
    LipCircle circle;
    Eigen::Vector2d pixel;
    double rho;
  };
  // edges[(mirror, outer side, path, circle)] -> exact points
  std::map<std::tuple<int, bool, int, int>, std::vector<Eigen::Vector2d>> edges;
  for (int k = 0; k < profiles; ++k) {
    const double phi = 2 * M_PI * (k + 0.5) / profiles;
    for (int band = 0; band < 2; ++band) {
      const LipPath paths[2] = {band == 0 ? LipPath::kDirect : LipPath::kViaReflex,
                                band == 0 ? LipPath::kViaMirror1 : LipPath::kViaMirror2};
      std::vector<Image> images;
      for (LipPath path : paths) {
        for (LipCircle circle : {LipCircle::kInner, LipCircle::kOuter}) {
          const auto px = ProjectLipPoint(model, path, circle, phi);
          if (px) images.push_back({path, circle, *px, (*px - centre).norm()});
        }
      }
      if (images.size() < 2) continue;
      for (bool outer : {false, true}) {
        size_t best = 0;
        for (size_t i = 1; i < images.size(); ++i) {
          if (outer ? images[i].rho > images[best].rho : images[i].rho < images[best].rho) best = i;
        }
        bool clear = true;
        for (size_t i = 0; i < images.size(); ++i) {
          if (i != best && images[i].path != images[best].path &&
              std::abs(images[i].rho - images[best].rho) < 1.5) {
            clear = false;
          }
        }
        // The band's own extent along the edge's path (the other circle's image) must be there.
        bool band_seen = false;
        for (size_t i = 0; i < images.size(); ++i) {
          if (i != best && images[i].path == images[best].path) band_seen = true;
        }
        if (!clear || !band_seen) continue;
        edges[{band + 1, outer, static_cast<int>(images[best].path),
               static_cast<int>(images[best].circle)}]
            .push_back(images[best].pixel);
      }
    }
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  for (auto& image : detections->images) {
    for (const auto& [key, points] : edges) {
      if (points.size() < 30) continue;  // the detector drops short edges
      LipEdgeObservation edge;
      edge.mirror = std::get<0>(key) == 1 ? Mirror::kOne : Mirror::kTwo;
      edge.edge = std::get<1>(key) ? BandEdge::kOuter : BandEdge::kInner;
      edge.path = static_cast<LipPath>(std::get<2>(key));
      edge.circle = static_cast<LipCircle>(std::get<3>(key));
      for (const auto& p : points) edge.points.push_back(p + Eigen::Vector2d(noise(rng), noise(rng)));
      image.lips.push_back(edge);
    }
  }
}

// Shifts every point of each lip edge across the edge (radially about the principal point) by
// one offset per edge, N(0, sigma_px^2), the same in every image: a detected lip edge's bias
// (blur, anti-aliasing) repeats in every image, since the rig does not move.
inline void AddSystematicLipOffsets(const RigParams& rig, double sigma_px, unsigned seed,
                                    Observations* detections) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_px);
  const Eigen::Vector2d centre(rig.camera[kCx], rig.camera[kCy]);
  std::vector<double> offsets;
  for (auto& image : detections->images) {
    for (size_t e = 0; e < image.lips.size(); ++e) {
      if (e >= offsets.size()) offsets.push_back(noise(rng));
      for (auto& p : image.lips[e].points) p += offsets[e] * (p - centre).normalized();
    }
  }
}

}  // namespace omni::testing

namespace omni::testing {

// The demo's session geometry on the fast path: a scene file's placements (random ones generated
// with the full-size rig, as `omnistereo render` does), corners from ComputeTruth through the
// truth rig at the scene's image size. Returns that rig (the truth the calibration must find).
inline RigParams MakeSceneSession(const RigParams& truth_full, const std::string& scene_file,
                                  SyntheticSession* s) {
  s->scene = synthetic::ReadSceneFile(scene_file, RigModel(truth_full));
  const RigParams truth = s->scene.width > 0
                              ? synthetic::RigAtImageSize(truth_full, s->scene.width, s->scene.height)
                              : truth_full;
  const RigModel model(truth);
  s->targets = s->scene.targets;  // distinct targets per image: session index = scene index
  s->truth.clear();
  for (const auto& image : s->scene.images) s->truth.push_back(synthetic::ComputeTruth(model, s->scene, image));
  return truth;
}

// The misaligned big rig without tangential distortion (so that the held dist_p1 = dist_p2 = 0
// are exact) through sample_configs/small_clean_scene.yaml's placements: the fast-path session
// of the Monte Carlo and considered-parameter tests. Returns the truth at the scene's size.
inline RigParams SmallCleanSessionWithoutTangential(SyntheticSession* s) {
  RigParams truth_rig = MisalignedRig();
  truth_rig.distortion[kDistP1] = truth_rig.distortion[kDistP2] = 0;
  return MakeSceneSession(
      truth_rig, std::string(OMNI_SOURCE_DIR) + "/sample_configs/small_clean_scene.yaml", s);
}

}  // namespace omni::testing
