#include "apps/health_cli.h"

#include <cstdio>
#include <optional>

#include <gflags/gflags.h>

#include "apps/common_flags.h"
#include "apps/progress.h"
#include "health/evidence.h"
#include "health/lip_reference.h"
#include "health/ring_matches.h"
#include "io/model_file.h"

DEFINE_string(tone, "srgb", "check, refine: how the photos encode light: srgb (cameras, JPEGs) | "
                            "linear (raw frames)");
DEFINE_string(bayer, "none", "check, refine: the photos are raw one-channel frames of this mosaic "
                             "(RGGB | BGGR | GRBG | GBRG) | none");

namespace omni::apps {

RigParams ReadStoredModel(const char* command) {
  if (FLAGS_model.empty()) {
    throw io::InputError("--model: expected the calibrated model file to " + std::string(command));
  }
  RigParams rig = io::ReadModelFile(FLAGS_model);
  // A single mirror's check and refine read its rim against the calibration photos' (health/
  // check.h); a folded rig's read the two rings' matches and the lips.
  if (std::string(command) == "refine" && rig.Single() &&
      (!rig.calibration || rig.calibration->lip_reference.empty())) {
    throw io::InputError(FLAGS_model + ": calibration.lip_reference: expected the mirror's rim as "
                         "its calibration photos showed it (a single mirror is refined from its "
                         "rim); calibrate with this version first");
  }
  if (!rig.calibration) {
    std::fprintf(stderr,
                 "%s: warning: %s has no calibration: section, so its own uncertainty is not "
                 "allowed for\n",
                 command, FLAGS_model.c_str());
  }
  return rig;
}

std::vector<health::ImageEvidence> CollectEvidenceFromFlags(const RigParams& stored,
                                                            const char* command) {
  const auto tone = io::ParseToneCurve(FLAGS_tone);
  if (!tone) throw io::InputError("--tone: expected srgb or linear, got '" + FLAGS_tone + "'");
  const auto bayer = io::ParseBayerPattern(FLAGS_bayer);
  if (!bayer) {
    throw io::InputError("--bayer: expected RGGB, BGGR, GRBG, GBRG or none, got '" + FLAGS_bayer +
                         "'");
  }
  const std::vector<std::string> paths = ImagesFromFlags();
  // Every photo is read (and its size checked) before the slow part starts.
  std::vector<cv::Mat> images;
  for (const std::string& path : paths) {
    cv::Mat image = io::ReadImage(path, *bayer);
    if (image.cols != stored.image_width || image.rows != stored.image_height) {
      throw io::InputError(path + ": expected the model's size " +
                           std::to_string(stored.image_width) + "x" +
                           std::to_string(stored.image_height) + ", got " +
                           std::to_string(image.cols) + "x" + std::to_string(image.rows));
    }
    images.push_back(image);
  }
  const RigModel model(health::AsObserved(stored));
  ProgressLine progress(command, static_cast<int>(paths.size()));
  // A single mirror has one ring: its evidence is the rim's edge alone (health/evidence.h).
  const bool one_ring = stored.Paths() < 2;
  std::optional<health::RingMatcher> matcher;
  if (!one_ring) {
    progress.Status("panorama maps of the stored model");
    matcher.emplace(model);
  }
  std::vector<health::ImageEvidence> evidence;
  for (size_t i = 0; i < paths.size(); ++i) {
    progress.Status((one_ring ? "finding the mirror's rim in " : "matching the rings and finding the lips in ") + paths[i]);
    evidence.push_back(health::CollectEvidence(images[i], paths[i], matcher ? &*matcher : nullptr,
                                               model, *tone, io::HasHalvedChroma(paths[i])));
    int lip_points = 0;
    for (const auto& edge : evidence.back().lips) lip_points += static_cast<int>(edge.points.size());
    char line[512];
    if (one_ring) {
      std::snprintf(line, sizeof(line), "%s: %s (%d points)", paths[i].c_str(),
                    lip_points ? "the rim's edge" : "the rim's edge not found", lip_points);
    } else {
      std::snprintf(line, sizeof(line), "%s: %zu ring-to-ring matches, %zu lip edges (%d points)",
                    paths[i].c_str(), evidence.back().matches.size(), evidence.back().lips.size(),
                    lip_points);
    }
    progress.Done(line);
  }
  progress.Finish();
  return evidence;
}

std::vector<LipReferenceBin> LearnLipReference(const RigParams& calibrated,
                                               const std::vector<std::string>& photos,
                                               io::BayerPattern bayer, io::ToneCurve tone,
                                               int* photos_used, double* rim_scene_px) {
  const RigModel model(calibrated);
  std::vector<health::ImageEvidence> evidence;
  for (const std::string& path : photos) {
    cv::Mat image;
    try {
      image = io::ReadImage(path, bayer);
    } catch (const io::InputError&) {
      continue;
    }
    if (image.cols != calibrated.image_width || image.rows != calibrated.image_height) continue;
    health::ImageEvidence one;
    one.file = path;
    one.lips = health::LipsUnderModel(image, path, model, tone, io::HasHalvedChroma(path));
    evidence.push_back(std::move(one));
  }
  *photos_used = static_cast<int>(evidence.size());
  const health::CheckOptions options;
  std::vector<LipReferenceBin> reference = health::LearnLipReference(model, evidence, options);
  *rim_scene_px = 0;
  if (calibrated.Single() && !reference.empty()) {
    RigParams stored = calibrated;
    if (!stored.calibration) stored.calibration = CalibrationInfo{};
    stored.calibration->lip_reference = reference;
    stored.calibration->lip_reference_sectors = options.azimuth_bins;
    stored.calibration->lip_reference_rim_scene_px = 0;
    *rim_scene_px = health::RimSceneSigma(stored, evidence, options);
  }
  return reference;
}

}  // namespace omni::apps
