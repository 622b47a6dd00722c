// The evidence of one image for the health check and the refinement (check.h, refine.h): its
// ring-to-ring matches and its lip edges, both found under the stored model. A single mirror
// (RigParams::Single) has no second ring to match against: its evidence is the rim's edge
// (detectors/lips/rim_edge.h), as calibrate measured it.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "health/check.h"
#include "health/ring_matches.h"
#include "io/image_file.h"

namespace omni::health {

// `image` as io::ReadImage gives it (8/16-bit grey or BGR, the model's size); `tone` how it
// encodes light; `chroma_halved` whether `file` is a JPEG with subsampled chroma (the lips are
// then placed on its own luma plane, detectors/lips/lip_detector.h). Grey images give matches but no
// lips (a single mirror's rim is found in grey ones too). `matcher` null: no matches (one ring).
ImageEvidence CollectEvidence(const cv::Mat& image, const std::string& file,
                              const RingMatcher* matcher, const RigModel& model,
                              io::ToneCurve tone, bool chroma_halved);

// The lips alone (the calibration's reference of them, lip_reference.h), found as above; a single
// mirror's rim edge where its model has no painted lip (lip_reference.h AsObserved: the circle
// its image's edge is, where that is not the rim).
std::vector<LipEdgeObservation> LipsUnderModel(const cv::Mat& image, const std::string& file,
                                               const RigModel& model, io::ToneCurve tone,
                                               bool chroma_halved);

}  // namespace omni::health
