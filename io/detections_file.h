// The detections file `omnistereo-detections/1` (tests/data/detections_example.yaml): what
// `detect` writes and `calibrate` / `triangulate` read: the typed observations of
// model/observations.h, checked when read (a lip edge's path must image its mirror's lip).
#pragma once

#include <string>
#include <vector>

#include "model/observations.h"

namespace omni::io {

// Throws InputError naming the file and key.
Observations ReadDetectionsFile(const std::string& path);
std::string DetectionsText(const Observations& detections);
// Atomic write.
void WriteDetectionsFile(const std::string& path, const Observations& detections);
// The detections as a file at `path` names them: each image's file and the session relative to
// that file's folder where they lie below it (else as given), so that the file is read the
// same from any working folder (`report` finds the session, `calibrate --report` the images).
Observations WithPathsRelativeToFile(Observations detections, const std::string& path);
// Each image of the detections file at `path` as a file that exists: its file as written
// (absolute, or relative to the working folder) or relative to the detections file's folder;
// else `fallback`'s path of that index (the session's image) where there is one, else as written.
std::vector<std::string> ImagePathsOf(const Observations& detections, const std::string& path,
                                      const std::vector<std::string>& fallback);

}  // namespace omni::io
