// The lip edges as the calibration photos showed them, so that the check measures change.
//
// A lip edge's detected points are biased in ways that depend on the rig and the camera, not on
// the scene: where mirror 2's red band thins to nothing at the reflex disc's rim, the blur merges
// its two edges and the outer one is placed up to 1.5 px inwards (the webcam preset at 1280x960,
// docs/experiments.md); a post's shadow, the JPEG's halved chroma pull similarly. That bias is the
// same in every photo of that camera, so the calibration absorbs part of it and the check, which
// expects the lip bins to be zero, would call an untouched rig DRIFTED. The calibration photos
// measure it: per lip bin (edge x azimuth sector, as residuals.h bins) the mean under the
// calibrated model over the photos and the scatter of one photo's mean about it. The check
// subtracts the mean and takes the scatter as the bin's error (residuals.h EstimateBins): what it
// tests is then whether the lips moved since calibration. The stored model's error is in the
// reference too, so those bins carry none of the model's covariance (check.cc).
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "health/check.h"
#include "model/rig_model.h"
#include "model/rig_params.h"

namespace omni::health {

// The stored model as its lips are measured: a single mirror whose image's edge is not its rim
// has its rim observation moved to the mirror circle its edge is
// (calibration.lip_reference_edge_radius, model/single_rim.h WithRimCircleAt); any other model as
// it is. The check, its evidence and calibrate's reference all measure under it.
RigParams AsObserved(const RigParams& stored);

// The stored calibration's lip bins by (edge, sector); empty for a model without them, or whose
// bins were cut into another number of sectors than the check's.
class LipReference {
 public:
  LipReference() = default;
  LipReference(const RigParams& stored, int azimuth_bins);
  const LipReferenceBin* Find(const std::string& edge, int sector) const;
  bool empty() const { return bins_.empty(); }
  int size() const { return static_cast<int>(bins_.size()); }

 private:
  std::map<std::pair<std::string, int>, LipReferenceBin> bins_;
};

// A bin's scatter learnt from few photos is itself uncertain: it is pooled with its edge's
// scatter, which counts as this many photos' worth (a scaled inverse-chi^2 prior).
constexpr double kPooledScatterPhotos = 4;

// The reference from the calibration photos' evidence (lips detected under the calibrated
// `model`; matches ignored). Empty with fewer than min_photos photos: their scatter cannot be
// told. A bin is kept where at least two photos have it.
std::vector<LipReferenceBin> LearnLipReference(const RigModel& model,
                                               const std::vector<ImageEvidence>& images,
                                               const CheckOptions& options, int min_photos = 3);

// A single mirror's rim: what one photo's scene moves the edge by as a whole, per coefficient of
// its scale, shift and tilt (px; check.h), from the calibration photos one at a time against
// `stored`'s reference: their coefficients' scatter (widened by n / (n - 1), as each photo is in
// the reference's mean), pooled with options.rim_scene_prior_px as kPooledScatterPhotos photos'
// worth: a few photos of one room cannot show the side of the rim a dark sleeve will cover.
double RimSceneSigma(const RigParams& stored, const std::vector<ImageEvidence>& images,
                     const CheckOptions& options);

}  // namespace omni::health
