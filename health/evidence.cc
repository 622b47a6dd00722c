#include "health/evidence.h"

#include <opencv2/imgproc.hpp>

#include "detectors/detect_image.h"
#include "detectors/lips/lip_detector.h"

namespace omni::health {

ImageEvidence CollectEvidence(const cv::Mat& image, const std::string& file,
                              const RingMatcher& matcher, const RigModel& model,
                              io::ToneCurve tone, bool chroma_halved) {
  ImageEvidence evidence;
  evidence.file = file;
  // Matching wants the image as it is (texture, not light): 8 bit.
  cv::Mat image8;
  if (image.depth() == CV_16U) image.convertTo(image8, CV_8U, 1.0 / 257);
  else image8 = image;
  if (image8.channels() == 4) cv::cvtColor(image8, image8, cv::COLOR_BGRA2BGR);
  evidence.matches = matcher.Match(image8);
  // Lips on the linear image, as detection does (detectors/detect_image.cc).
  if (image.channels() >= 3) {
    detectors::LipDetectorOptions lip_options;
    lip_options.chroma_halved = chroma_halved;
    if (chroma_halved) {
      lip_options.luma = io::ReadStoredLuma(file);
      if (lip_options.luma.size() != image.size()) lip_options.luma = cv::Mat();
    }
    evidence.lips = detectors::DetectLips(detectors::LipInput(io::LinearImage(image, tone)), model,
                                          lip_options);
  }
  return evidence;
}

}  // namespace omni::health
