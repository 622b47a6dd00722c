#include "health/evidence.h"

#include <opencv2/imgproc.hpp>

#include "detectors/detect_image.h"
#include "detectors/common/views.h"
#include "detectors/lips/lip_detector.h"
#include "detectors/lips/rim_edge.h"

namespace omni::health {

ImageEvidence CollectEvidence(const cv::Mat& image, const std::string& file,
                              const RingMatcher* matcher, const RigModel& model,
                              io::ToneCurve tone, bool chroma_halved) {
  ImageEvidence evidence;
  evidence.file = file;
  // Matching wants the image as it is (texture, not light): 8 bit.
  cv::Mat image8;
  if (image.depth() == CV_16U) image.convertTo(image8, CV_8U, 1.0 / 257);
  else image8 = image;
  if (image8.channels() == 4) cv::cvtColor(image8, image8, cv::COLOR_BGRA2BGR);
  if (matcher) evidence.matches = matcher->Match(image8);
  evidence.lips = LipsUnderModel(image, file, model, tone, chroma_halved);
  return evidence;
}

std::vector<LipEdgeObservation> LipsUnderModel(const cv::Mat& image, const std::string& file,
                                               const RigModel& model, io::ToneCurve tone,
                                               bool chroma_halved) {
  const RigParams& rig = model.params();
  if (rig.Single() && !HasLip(rig, Mirror::kOne)) {
    // The rim's edge, as detect finds it (detectors/detect_image.cc): any image, linear light.
    const cv::Mat grey = detectors::ToGrey(io::LinearImage(image, tone));
    auto rim = detectors::DetectRimEdge(grey, model);
    if (!rim) return {};
    return {std::move(*rim)};
  }
  // Grey images have no colours to tell the lips by.
  if (image.channels() < 3) return {};
  // On the linear image, as detection does (detectors/detect_image.cc).
  detectors::LipDetectorOptions lip_options;
  lip_options.chroma_halved = chroma_halved;
  if (chroma_halved) {
    lip_options.luma = io::ReadStoredLuma(file);
    if (lip_options.luma.size() != image.size()) lip_options.luma = cv::Mat();
  }
  return detectors::DetectLips(detectors::LipInput(io::LinearImage(image, tone)), model,
                               lip_options);
}

}  // namespace omni::health
