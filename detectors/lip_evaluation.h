// The lip detector judged against the exact images of the lips' 3D circles in the true rig
// (bench/eval_lips): per edge (mirror, side, circle, path) the points kept, their distance to the
// image of their labelled circle (DistanceToLipCircleImage), to the band edge with the occlusion
// followed (DistanceToLipEdgeImage), the edge as a curve and as the detector's ellipse fit gives
// it, the band's paint likeness, contrast and noise (LipEdgeFit); and the lip-only intrinsics.
#pragma once

#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "detectors/lips/lip_detector.h"
#include "model/rig_model.h"

namespace omni::detectors {

class LipEvaluation {
 public:
  explicit LipEvaluation(const RigModel& truth) : truth_(truth) {}

  // One image's edge fits. *point_lines (may be null) gets every point with a true circle image:
  // "point MIRROR PATH u v signed_px" (+ away from the principal point).
  void AddImage(const std::vector<LipEdgeFit>& fits, std::string* point_lines = nullptr);

  // DetectLipEdges on one image (linear, 8 or 16 bit, as DetectImage feeds it) with `prior`, its
  // process CPU time kept, then AddImage.
  void DetectAndAdd(const cv::Mat& linear, const RigModel& prior, const LipDetectorOptions& options,
                    std::string* point_lines = nullptr);

  // The table: a header and one row per edge (columns as bench/eval_lips.cc's header says).
  std::string Table() const;
  // The table, DetectAndAdd's CPU time per image (mean, max) and the lip-only fit of every edge
  // from `nominal` and from the true rig (LipOnlyFitLine); newline-terminated.
  std::string Report(const RigModel& nominal) const;
  // Every edge added, for a pooled lip-only fit.
  const std::vector<LipEdgeObservation>& edges() const { return edges_; }

 private:
  struct EdgeStats {
    std::vector<double> distances, band, contrast, noise;
    std::vector<double> edge_distances;  // to the band edge with the occlusion followed
    // The edge as a curve: per point, the mean signed distance of the points within +-2.5 deg
    // of its azimuth (about the principal point) in the same image, what a local fit of the edge
    // there would be off by (the points' own scatter averages out, their common offset stays).
    std::vector<double> curve_offsets;
    std::vector<double> fit_distances;  // the fitted ellipse at each point, from the truth
    int on_rim = 0;                     // points whose band edge is the reflex disc's rim
    double signed_sum = 0;
    int images = 0;
    int no_truth = 0;  // points where the true rig images no point of their circle
  };
  const RigModel& truth_;
  std::map<std::tuple<int, std::string, std::string, std::string>, EdgeStats> stats_;
  std::vector<LipEdgeObservation> edges_;
  std::vector<double> cpu_ms_;  // DetectAndAdd's, per image
};

// The lip-only fit (InitialIntrinsicsFromLips) of `edges` from `prior`, against the true rig's f
// and principal point: one line, newline-terminated, naming the prior as `name`.
std::string LipOnlyFitLine(const char* name, const std::vector<LipEdgeObservation>& edges,
                           const RigModel& prior, const RigParams& truth);

}  // namespace omni::detectors
