// The parameters of a (possibly misaligned) rig, grouped in the blocks a calibration fixes or
// refines independently (docs/design.md, Conventions; tests/data/model_example.yaml). Plain data: the maths
// that uses them lives in rig_model.h (non-central) and ideal_model.h (SVP).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "model/camera.h"
#include "model/conic.h"
#include "model/ideal_model.h"
#include "model/mirror_profile.h"
#include "model/mount.h"
#include "model/profile_fit.h"
#include "model/rig_blocks.h"

namespace omni {

enum class ModelKind { kIdeal, kNoncentral };

// A flat coloured annulus at a mirror's rim, in that mirror's body frame: r_inner <= r <= r_outer
// at height z.
struct Lip {
  std::string color;
  double r_inner = 0, r_outer = 0, z = 0;
};

// A mirror profile the calibration held (not refined) but considered, and what is known of it:
// the tolerance check of its peak-to-valley (design/tolerance.h) is decided from this.
struct HeldProfileInfo {
  int mirror = 1;  // 1 or 2
  // What was assumed or measured before the photos: "tolerance" (the machining tolerance,
  // profile_sigma_mm per term: an assumption) or "scan" (a measured profile's fit).
  std::string prior;
  // The radii the terms were held over (the profile's shape; a held zero profile is not written
  // as a `profile:` map, so its radii are kept here).
  double r_min = 0, r_max = 0;
  std::vector<double> prior_covariance;  // kProfileTerms^2, row-major, mm^2
  // What this session's data tell of the terms with the rig's refined parameters free (the Schur
  // complement S_c|x, 1/mm^2, row-major); empty where the data were not asked (a profile held
  // whatever they show: profile: hold). Only recorded where the data show no radial pattern
  // (profile: auto held it for want of evidence), so the held terms are their estimate too.
  std::vector<double> data_information;
};

// One lip bin of the health check (health/check.h: an edge's points in one azimuth sector) as
// the calibration photos showed it under the calibrated model: the edge detector's bias there (a
// thin band's blurred edges pull on each other, a post's shadow, the JPEG's chroma), which is the
// same in every photo of that camera, and how much the bin's mean scattered from photo to photo.
// The check measures change from it (health/lip_reference.h).
struct LipReferenceBin {
  std::string edge;        // "via_mirror2 r_outer" (path, circle)
  double azimuth_deg = 0;  // the sector's centre
  int photos = 0;          // calibration photos with this bin
  double mean_px = 0;      // the bin's mean over them, signed across the edge
  double scatter_px = 0;   // standard deviation of one photo's bin mean about it
};

// What a calibration adds to a model file (`calibration:` section).
struct CalibrationInfo {
  std::vector<std::string> parameters;  // names in the order of the covariance, e.g. mirror1.tx
  std::vector<double> values;
  std::vector<double> sigma;
  std::vector<double> covariance;       // row-major, parameters.size()^2
  // Optional (absent in older files): the covariance from the pixel noise alone, without the
  // considered parameters' share (held coordinates, the detectors' biases), same layout. More
  // photos shrink this part (design/decide_photos.h predicts with it).
  std::vector<double> noise_covariance;
  double rms_px = 0;
  int n_observations = 0;
  int n_outliers = 0;
  std::vector<double> per_mirror_rms_px;
  // Optional (absent in older files): what the data could not determine, and the lips.
  std::vector<std::string> unobservable;        // parameter names, never given a value
  std::vector<std::string> unobservable_hints;  // one per name: what data would determine it
  int n_rejected = 0;        // observations left out (outliers, not projectable, failed poses)
  int n_lip_points = 0;      // lip edge points used
  double lip_rms_px = 0;
  std::vector<HeldProfileInfo> held_profiles;  // optional (absent in older files)
  // The lip bins of the calibration photos (absent in older files, and for sessions of fewer
  // than three photos or without lips); lip_reference_sectors: their number of azimuth sectors.
  std::vector<LipReferenceBin> lip_reference;
  int lip_reference_sectors = 0;
  // A single mirror whose image's edge is not its rim (model/single_rim.h RimEdgeIsTheRim): the
  // radius (mm, at this model's scale) of the mirror's circle that the edge is, about which the
  // reference's bins were measured; 0: the rim itself (absent in older files).
  double lip_reference_edge_radius = 0;
  // A single mirror: what one photo's scene moves its rim's edge by as a whole, per coefficient of
  // its scale, shift and tilt (px; health/lip_reference.h RimSceneSigma; 0: not measured).
  double lip_reference_rim_scene_px = 0;
  std::string session;
  int images = 0;
  std::string targets;
  std::string tool_version;
  std::string date;
};

struct RigParams {
  ModelKind kind = ModelKind::kIdeal;
  // The layout and the lens (types.h). A single-mirror rig uses camera, distortion, mirror 1's
  // shape (R, K: conic.h, instead of the folded rig's c1, k1), pose and profile; its mirror 2,
  // reflex and d are unused (zero).
  RigKind rig = RigKind::kFolded;
  LensKind lens = LensKind::kPerspective;
  int image_width = 1280, image_height = 960;

  // Parameter blocks (the order inside each block is fixed and named in the comments).
  std::array<double, 5> camera{};        // fx, fy, cx, cy, skew
  std::array<double, 5> distortion{};    // dist_k1, dist_k2, dist_p1, dist_p2, dist_k3
  std::array<double, 2> mirror1_shape{}; // c1, k1 (a single-mirror rig: R, K)
  std::array<double, 2> mirror2_shape{}; // c2, k2
  std::array<double, 5> mirror1_pose{};  // cam_from_mirror1: rx, ry (tilt), tx, ty, tz (mm)
  std::array<double, 5> mirror2_pose{};  // cam_from_mirror2
  std::array<double, 3> reflex{};        // in mirror 1's body: rx, ry (tilt), dz (mm)
  // Each mirror's profile correction (mirror_profile.h): sag_p1..sag_p4, sag_cos2, sag_sin2 (mm),
  // read only where the shape below is present.
  std::array<double, kProfileTerms> mirror1_profile{};
  std::array<double, kProfileTerms> mirror2_profile{};

  // Fixed design data (mm). A single-mirror rig: r_sys its rim's radius, r_cam the radius of
  // the centre it does not use (the camera's own reflection), vertex_z its vertex's height in M1
  // (conic_sheet.h); r_ref and d zero.
  double d = 0, r_sys = 0, r_ref = 0, r_cam = 0;
  double vertex_z = 0;
  Lip lip1, lip2;
  // The profiles' fixed part: radii, ripple; present false (the default) = exact quadrics.
  ProfileShape profile1, profile2;
  // Each mirror's measured profile (index 0: mirror 1), where the model file gave one
  // (`profile_from:`): its coefficients above are the scan's fit; the calibration's prior.
  std::array<std::optional<MeasuredProfile>, 2> measured_profile;
  // The posts that hold the rig together (model/mount.h); present false: none (a glass tube).
  Mount mount;

  std::optional<CalibrationInfo> calibration;

  bool Single() const { return rig == RigKind::kSingle; }
  // The optical paths (rings) it has: 2 folded, 1 single.
  int Paths() const { return Single() ? 1 : 2; }
  Pinhole<double> Intrinsics() const { return PinholeFromBlock(camera.data()); }
  RadTan<double> Distortion() const { return RadTanFromBlock(distortion.data()); }
  DesignParams Design() const {
    return DesignParams{mirror1_shape[kShapeC], mirror2_shape[kShapeC], mirror1_shape[kShapeK],
                        mirror2_shape[kShapeK], d, r_sys};
  }
  // The SVP model with the same design and intrinsics (misalignment and distortion dropped).
  IdealModel Ideal() const {
    return IdealModel{mirror1_shape[kShapeC], mirror2_shape[kShapeC], mirror1_shape[kShapeK],
                      mirror2_shape[kShapeK], d, r_sys, r_ref, r_cam, Intrinsics()};
  }
};

// The raw parameter blocks one projection reads (pointers into RigParams-like storage, double
// or Ceres jets), indexed by RigBlockId: every optical path (rig_model.h, lip.h) takes this one
// bundle. A path leaves the blocks it does not use unread, so a caller may leave them nullptr
// (the mirror-1 path reads neither mirror2 block); a profile block left nullptr is the exact conic.
template <typename T>
class RigBlocks {
 public:
  RigBlocks() { blocks_.fill(nullptr); }
  // blocks[i] as block ids[i] (a cost's parameter list, in its order); the others nullptr.
  template <size_t N>
  RigBlocks(const std::array<RigBlockId, N>& ids, const T* const* blocks) : RigBlocks() {
    for (size_t i = 0; i < N; ++i) blocks_[ids[i]] = blocks[i];
  }
  const T* operator[](RigBlockId id) const { return blocks_[id]; }
  const T*& operator[](RigBlockId id) { return blocks_[id]; }

 private:
  std::array<const T*, kRigBlockCount> blocks_;
};
// The blocks of a RigParams.
RigBlocks<double> RigBlocksOf(const RigParams& rig);

// An ideal rig from a design: r_ref from the design, lips at each mirror's rim (3 mm wide,
// blue on mirror 1, red on mirror 2).
// A mirror's default profile radii: the annulus its ring sees (mirror 1: r_ref..r_sys, outside
// the reflex disc; mirror 2: r_cam..r_sys, outside the hole).
ProfileShape DefaultProfileShape(const RigParams& rig, Mirror mirror);

RigParams MakeIdealRig(const DesignParams& theta, double r_cam, const Pinhole<double>& cam,
                       int image_width, int image_height);

// A single-mirror rig (RigKind::kSingle) of that conic and lens, aligned: the mirror's axis the
// camera's, its vertex vertex_z above the camera (a perspective lens at a hyperboloid's far focus:
// CentralMirror::CameraBelowVertexMm); the used annulus r_cam..r_sys; no lip paint (the rim
// itself is the mark: lip1 a circle of radius r_sys at the rim's height, colour "").
RigParams MakeSingleRig(const Conic<double>& mirror, LensKind lens, double vertex_z, double r_sys,
                        double r_cam, const Pinhole<double>& cam, int image_width,
                        int image_height);

// Whether the rig has that mirror's painted lip (a single-mirror rig: none for mirror 2; its
// mirror 1 only where the model file gives one).
bool HasLip(const RigParams& rig, Mirror mirror);

}  // namespace omni
