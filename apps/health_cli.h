// What `check` and `refine` share: the stored model, the photos of --image/--images
// read as the camera wrote them (--bayer, --tone), and their evidence (health/evidence.h).
#pragma once

#include <string>
#include <vector>

#include "health/check.h"
#include "io/image_file.h"
#include "model/rig_params.h"

namespace omni::apps {

// --model read; InputError if missing, or for `refine` a single-mirror model (no second ring to
// match against). A model without `calibration:` is accepted with a warning on stderr (the check
// then has no model uncertainty to allow for).
RigParams ReadStoredModel(const char* command);

// Every photo's matches and lips under `stored`, with a progress line; InputError naming the file
// for a photo that cannot be read or is not the model's size.
std::vector<health::ImageEvidence> CollectEvidenceFromFlags(const RigParams& stored,
                                                            const char* command);

// The calibration photos' lip bins under the calibrated model (health/lip_reference.h), for its
// `calibration:` section. Photos that cannot be read (a calibration from a detections file whose
// images are elsewhere) or are not the model's size are left out; *photos_used counts the rest.
// A single mirror's: also *rim_scene_px (health/lip_reference.h RimSceneSigma; else 0).
std::vector<LipReferenceBin> LearnLipReference(const RigParams& calibrated,
                                               const std::vector<std::string>& photos,
                                               io::BayerPattern bayer, io::ToneCurve tone,
                                               int* photos_used, double* rim_scene_px);

}  // namespace omni::apps
