// The start of a single-mirror camera nobody designed for us (`omnistereo init --design
// single_mirror`): from the mirror's rim found in the photos (lips/mirror_rim.h) and what the
// builder knows (the rim's measured diameter, the mirror's kind, the lens, perhaps a rough
// camera distance and the lens's focal length or magnification), an aligned single rig
// (model/rig_params.h MakeSingleRig) and what a calibration of it should estimate.
//
// The start's one assumption about a mirror nobody measured: the rim reflects the camera's ray
// at the rim to the horizon (90 deg from the axis), as most catadioptric mirrors are cut. For the
// central cameras (model/central_mirror.h) that puts the rim in the plane of the focus the mirror
// wraps, so R equals the rim's radius (a conic's semi-latus rectum). In general, with the rim
// seen at angle alpha from the lens's axis (telecentric: alpha = 0), the surface's slope at the
// rim is dz/dr = tan(pi/4 - alpha/2), which with the conic constant K gives R (RimConic).
//
// The rim's image radius rho (px) then fixes the lens: perspective f = rho / tan(alpha),
// telecentric m = rho / r (px per mm). What fixes alpha (perspective):
//   focal_px given: alpha = atan(rho / f);
//   else camera_distance given: the alpha whose conic puts the vertex that far from the camera
//     (a hyperboloid: the camera at its far focus, e = 1 + r / d);
//   else a hyperboloid of K = -2 with the camera at its far focus, a paraboloid seen from two rim
//     diameters away (both stated as assumptions in the lines); a sphere has no such default.
// A central fit instead (unified_xi, unified_gamma: cv::omnidir's or Mei's xi and gamma, px):
// the central camera it describes scaled by the rim (model/central_mirror.h
// CentralMirrorFromUnified): a hyperboloid with the lens at its far focus, or a paraboloid
// behind a telecentric lens; no assumption about the rim's reflection.
// The diameter check: where two of these are given (focal_px and camera_distance, or a
// telecentric lens's magnification; with a unified fit: camera_distance, focal_px), the rim in the photos must agree with the diameter within
// the tolerances below; a diameter given as a radius (2x), in cm (10x) or inches misses by far
// more.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/lips/mirror_rim.h"
#include "model/calibration_settings.h"
#include "model/conic.h"
#include "model/rig_params.h"

namespace omni::detectors {

enum class MirrorKnowledge { kHyperbolic, kParabolic, kSpherical, kUnknown };
// hyperbolic | parabolic | spherical | unknown; false for another name.
bool ParseMirrorKnowledge(const std::string& name, MirrorKnowledge* kind);
const char* MirrorKnowledgeName(MirrorKnowledge kind);

// The rim's diameter a start is drawn at when nothing known fixes the scale (mm).
constexpr double kNominalDiameterMm = 50;

// What the builder knows. Field names are the command's flag names: the reasons below start
// with them.
struct SingleMirrorKnowledge {
  // mm, the rim's measured diameter: the model's scale. 0: not measured: the scale from the
  // magnification or the camera distance where given, else kNominalDiameterMm (the start's
  // lines say the absolute size is then not determined).
  double mirror_diameter = 0;
  MirrorKnowledge mirror = MirrorKnowledge::kUnknown;
  LensKind lens = LensKind::kPerspective;
  double camera_distance = 0;  // mm, rough, the lens's centre to the mirror's vertex; 0: unknown
  double focal_px = 0;         // perspective: the lens's focal length in px; 0: unknown
  double magnification = 0;    // telecentric: px per mm (magnification / pixel pitch); 0: unknown
  // A central fit's unified model (both > 0, or both 0: none); gamma in px.
  double unified_xi = 0, unified_gamma = 0;
  // Tolerances of the diameter check (relative). Perspective: the camera distance the rim's
  // angle and the diameter imply against camera_distance (rough, and the rim's reflection at the
  // horizon is assumed). Telecentric: the rim's px per mm against magnification (a lens
  // specification; the rim found within a pixel).
  double distance_tolerance = 0.3;
  double magnification_tolerance = 0.05;
  // The centre the camera's own reflection hides, as a share of the rim's radius (r_cam).
  double r_cam_fraction = 0.15;
  // Empty if consistent, else "<field>: expected ..." (a telecentric lens with a hyperboloid, a
  // sphere seen in perspective without camera_distance or focal_px, a flag of the other lens).
  std::string Check() const;
};

// The conic whose rim (radius r, mm) reflects a ray arriving at angle alpha (rad) from the axis
// to 90 deg from the axis, for conic constant K: R and the rim's sag. Nullopt if no sheet
// through the vertex has that slope at r (a hyperboloid too open for so steep a rim).
struct RimConicResult {
  Conic<double> conic;
  double rim_sag = 0;
};
std::optional<RimConicResult> RimConic(double r, double K, double alpha);

struct SingleMirrorStart {
  RigParams rig;                      // rig: single, kind: ideal, aligned
  MirrorRim rim;                      // as found (px)
  double rim_angle_rad = 0;           // perspective: the rim's angle from the lens axis
  double camera_distance_mm = 0;      // the lens's centre to the vertex (telecentric: as placed)
  std::vector<std::string> estimate;  // the session's estimate
  std::vector<std::pair<std::string, ShapePrior>> priors;  // the session's priors
  // The session's comment lines (no "# ", no newline): what each choice means.
  std::vector<std::string> comments;
  // What was found and assumed, one line each, for the user.
  std::vector<std::string> lines;
};

// The start from a found rim (rim.found must hold) in photos of width x height. Nullopt with
// *why ("<field>: ...") when the knowledge fails Check() or disagrees with the rim.
std::optional<SingleMirrorStart> SingleMirrorStartFromRim(const MirrorRim& rim,
                                                          const SingleMirrorKnowledge& knowledge,
                                                          int width, int height,
                                                          std::string* why);

// The rim found in the photos (grey, one size), then SingleMirrorStartFromRim. Nullopt with
// *why: "images: no mirror rim found in the N photos: <FindMirrorRim's why>" or the knowledge's
// reason.
std::optional<SingleMirrorStart> SingleMirrorStartFromPhotos(
    const std::vector<cv::Mat>& grey_images, const SingleMirrorKnowledge& knowledge,
    std::string* why, const MirrorRimOptions& rim_options = {});

// At most max_images of the photos, spread evenly over the list, read as grey (the rim finder's
// median needs a few photos, not all). Throws io::InputError naming an unreadable photo.
std::vector<cv::Mat> GreyPhotosForRim(const std::vector<std::string>& images,
                                      size_t max_images = 12);

}  // namespace omni::detectors
