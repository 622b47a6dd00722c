// What the detectors find in an image, and what the calibration and triangulation use: target
// corners per ring, and lip edge points labelled with the lip circle and the optical path they
// image (model/lip.h). The detections file (io/detections_file.h) reads and writes these
// and checks them; everything else takes them typed.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/types.h"

namespace omni {

// The four optical paths by which the camera sees a lip (model/lip.h).
enum class LipPath { kDirect, kViaMirror1, kViaReflex, kViaMirror2 };
// A lip annulus' two boundary circles: r_inner and r_outer in its mirror's body frame.
enum class LipCircle { kInner, kOuter };
// Which boundary of a coloured band in the image: the inner (smaller radius about the principal
// point) or the outer.
enum class BandEdge { kInner, kOuter };

// Names as in the detections file: direct | via_mirror1 | via_reflex | via_mirror2, r_inner |
// r_outer, inner | outer. Parse* return false for an unknown name.
const char* LipPathName(LipPath path);
bool ParseLipPath(const std::string& name, LipPath* path);
const char* LipCircleName(LipCircle circle);
bool ParseLipCircle(const std::string& name, LipCircle* circle);
const char* BandEdgeName(BandEdge edge);
bool ParseBandEdge(const std::string& name, BandEdge* edge);

// The mirror that owns the lip a path images: direct and via_mirror1 image the blue lip of
// mirror 1, via_reflex and via_mirror2 the red lip of mirror 2.
inline Mirror LipOwner(LipPath path) {
  return path == LipPath::kDirect || path == LipPath::kViaMirror1 ? Mirror::kOne : Mirror::kTwo;
}

// A target corner seen in one ring.
struct CornerObservation {
  int target = 0;  // index into the session's targets
  int id = 0;      // corner id (model/target.h)
  Mirror mirror = Mirror::kOne;  // kOne: outer ring, kTwo: inner ring
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

// Sub-pixel points of one coloured band's edge. Our detector labels every edge with the circle
// and path it images (where the model says it is unambiguous); a file written by hand or by
// another tool may leave them out, and the calibration then refuses the edge.
struct LipEdgeObservation {
  Mirror mirror = Mirror::kOne;  // whose lip, the band's paint
  BandEdge edge = BandEdge::kInner;
  std::optional<LipCircle> circle;
  std::optional<LipPath> path;  // if both are set, LipOwner(*path) == mirror
  std::vector<Eigen::Vector2d> points;
};

struct ImageObservations {
  std::string file;  // as written (relative to the detections file's folder if below it)
  int width = 0, height = 0;
  std::vector<CornerObservation> corners;
  std::vector<LipEdgeObservation> lips;
};

// A session's observations, image by image.
struct Observations {
  std::string session;  // the session file they came from
  std::vector<ImageObservations> images;
};

}  // namespace omni
