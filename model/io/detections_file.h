// The detections file `omnistereo-detections/1` (shared/formats/detections_example.yaml): what
// `detect` writes and `calibrate` / `triangulate` read.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace omni::io {

struct CornerObservation {
  int target = 0;   // index into the session's targets
  int id = 0;       // corner id (model/target.h)
  int mirror = 1;   // 1 (outer ring) or 2 (inner ring)
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

// Sub-pixel edge points of one coloured lip band edge, and which 3D circle and optical path the
// detector says they image.
struct LipEdge {
  int mirror = 1;           // whose lip: 1 blue, 2 red
  std::string edge;         // inner | outer (radius in the image)
  std::string circle;       // which 3D circle: r_inner | r_outer of that lip
  std::string path;         // direct | via_mirror1 | via_reflex | via_mirror2
  std::vector<Eigen::Vector2d> points;
};

struct ImageDetections {
  std::string file;         // as written (relative to the detections file's folder if below it)
  int width = 0, height = 0;
  std::vector<CornerObservation> corners;
  std::vector<LipEdge> lips;
};

struct Detections {
  std::string session;      // the session file it came from
  std::vector<ImageDetections> images;
};

// Throws InputError naming the file and key.
Detections ReadDetectionsFile(const std::string& path);
std::string DetectionsText(const Detections& detections);
// Atomic write.
void WriteDetectionsFile(const std::string& path, const Detections& detections);

}  // namespace omni::io
