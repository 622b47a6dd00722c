// The session file `omnistereo-session/1` (tests/data/session_example.yaml): the starting
// model, the images, the targets that may appear, what to estimate and how.
//
//   format: omnistereo-session/1
//   model: model.yaml                 # relative to the session file
//   images: [images/*.png]            # paths or globs (`*`, `?` in the file name), sorted
//   targets:
//     - {type: chessboard, rows: 6, cols: 8, square: 40.0}
//     - {type: apriltag_grid, family: tag36h11, rows: 5, cols: 5, tag_size: 30.0, spacing: 0.3, first_id: 0}
//     - {type: kalibr_aprilgrid, rows: 2, cols: 3, tag_size: 45.0, spacing: 0.3, first_id: 0}
//   lips: true                        # optional (default true): detect and use the lips
//   estimate: [camera, distortion, mirror1_pose, mirror2_pose, reflex]   # parameter groups
//   priors: {mirror1_shape: {sigma_c: 0.05, sigma_k: 0.01}, mirror2_shape: {...}}  # optional
//   consider: {dist_p1: 5.0e-4, dist_p2: 5.0e-4}   # optional: held parameters' sigma, carried
//                                                  # into the covariance ({} for none)
//   profile: auto                     # optional: each mirror's profile: auto | free | hold | off
//   profile_sigma_mm: 0.002           # optional: the machining tolerance per profile term (mm)
//   noncentral: auto                  # optional, a single mirror's mirror1_pose: auto | free
//   solver: {max_iterations: 100, loss: huber, loss_scale_px: 1.0, outlier_px: 3.0, threads: 2}
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "io/image_file.h"
#include "model/calibration_settings.h"
#include "model/target.h"

namespace omni::io {

struct Session {
  std::string path;                  // the session file as given
  std::string model_path;            // resolved against the session file's folder
  std::vector<std::string> images;   // resolved, globs expanded, sorted
  std::vector<TargetSpec> targets;
  bool use_lips = true;
  // `bayer: RGGB|BGGR|GRBG|GBRG`: the images are raw one-channel frames of that mosaic and are
  // demosaiced when read (io/image_file.h); absent or none: images as the camera wrote them.
  BayerPattern bayer = BayerPattern::kNone;
  // `tone: srgb|linear`: how the images encode light (image_file.h). Absent: srgb, as colour
  // cameras and JPEGs write, or linear for raw Bayer frames.
  ToneCurve tone = ToneCurve::kSrgb;
  std::vector<std::string> estimate; // groups: camera, distortion, mirror1_pose, mirror2_pose,
                                     // reflex, mirror1_shape, mirror2_shape
  std::map<std::string, ShapePrior> priors;  // key: mirror1_shape | mirror2_shape
  // Held parameters (dist_p1, dist_p2, dist_k3, skew) whose uncertainty the covariance carries
  // (calib::CalibrationOptions::considered_sigma); absent: the calibration's default.
  std::optional<std::map<std::string, double>> consider;
  // Each mirror's profile (calib::CalibrationOptions::profile, profile_sigma_mm); empty / 0: the
  // calibration's default.
  std::string profile;
  // A single mirror's non-central part (calib::CalibrationOptions::noncentral); empty: the default.
  std::string noncentral;
  double profile_sigma_mm = 0;
  SolverOptions solver;
};

// The parameter groups a session may name in `estimate:`.
const std::vector<std::string>& EstimableGroups();

// Reads and validates a session file. Throws InputError naming the file and key. Globs that match
// nothing are an error; image files are not opened here.
Session ReadSessionFile(const std::string& path);

// The files a session's `images:` entry names: a plain path as it is, a glob's matches sorted
// (none: empty).
std::vector<std::string> ExpandImagePattern(const std::string& pattern);

// Targets written as session entries (a YAML list of maps, or one map), as `init --targets`
// takes them; errors name `what` and the entry.
std::vector<TargetSpec> ParseTargetList(const std::string& text, const std::string& what);

// One target as a session file's `targets:` entry: "{type: chessboard, rows: 6, cols: 8,
// square: 40}" (what `omnistereo target` prints for the sheet it draws).
std::string TargetEntryText(const TargetSpec& target);

// The YAML text of a session; paths are written relative to `base_dir` (the folder the session
// file will be written to) when they lie below it.
std::string SessionText(const Session& session, const std::string& base_dir);

}  // namespace omni::io
