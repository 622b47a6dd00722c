// The detections file `omnistereo-detections/1` (tests/data/detections_example.yaml): what
// `detect` writes and `calibrate` / `triangulate` read: the typed observations of
// model/observations.h, checked when read (a lip edge's path must image its mirror's lip).
#pragma once

#include <string>

#include "model/observations.h"

namespace omni::io {

// Throws InputError naming the file and key.
Observations ReadDetectionsFile(const std::string& path);
std::string DetectionsText(const Observations& detections);
// Atomic write.
void WriteDetectionsFile(const std::string& path, const Observations& detections);

}  // namespace omni::io
