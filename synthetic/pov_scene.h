// POV-Ray scene export of a rig model (ideal or misaligned) with targets, markers and a room, so
// an independent ray tracer renders images through the true mirror geometry.
//
// Frames: the scene is written in the camera frame C (docs/design.md, Conventions; x right, y down, z forward)
// mapped into POV-Ray's left-handed, y-up world by (x, y, z)_POV = (x, -y, z)_C. That map is a
// reflection, and so is the change of handedness, so reflections and distances are preserved.
// Camera: POV-Ray samples pixel i at screen x_s = (i + 0.5)/W - 0.5 and row j at
// y_s = 0.5 - (j + 0.5)/H along direction + x_s right + y_s up. With right = (W/fx, 0, 0),
// up = (s H/(fx fy), H/fy, 0) and direction = (a, b, 1) (derived in pov_scene.cc), that ray is
// exactly (x_n, -y_n, 1) for the pixel-centre convention u = fx x_n + s y_n + cx, v = fy y_n + cy:
// any principal point and skew, no cropping. Lens distortion is applied after rendering.
// A telecentric lens (single-mirror rigs) is an orthographic camera with the same right and up
// starting at (a, b, 0): pixel (u, v)'s ray starts at (x_mm, -y_mm, 0) and runs along +z.
// A single-mirror rig (rig: single) draws its conic, a dark centre inside r_cam and a dark
// housing ring outside the rim; no reflex disc, no mirror 2 (docs/design.md, POV-Ray rendering).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "model/rig_params.h"
#include "model/target.h"

namespace omni::synthetic {

// A small self-lit sphere (for tying our projection to POV-Ray's: its image centroid).
struct Marker {
  Eigen::Vector3d center_in_cam;
  double radius_mm = 1.0;
};

// A target's printed sheet (model/target.h: printed face towards -z of the target frame, x right
// and y down seen from the printed side, the sheet rectangle SheetBounds(spec)). Chessboards are
// drawn procedurally (squares of spec.square_mm, corner (r, c) at (c, r) * square); tag grids as
// a sharp image map (tag_texture.h) stretched exactly over the sheet rectangle.
struct TargetSheet {
  Eigen::Matrix3d cam_from_target_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d cam_from_target_translation = Eigen::Vector3d::Zero();
  TargetSpec spec;
  std::string texture;  // tag grids: the PNG's file name, in the .pov's folder
};

struct SceneContent {
  std::vector<Marker> markers;
  std::vector<TargetSheet> targets;
  // A textured, self-lit box room around the rig for dense stereo: walls at x, y = +-half size,
  // floor and ceiling at z_C = room_floor_mm and room_ceiling_mm (z_C is the rig's axis, up).
  bool room = false;
  double room_half_size_mm = 3000.0;
  double room_floor_mm = -1200.0;
  double room_ceiling_mm = 1800.0;
  // The walls' texture: granite with speckles (what stereo and the health check match on), or
  // plain grey (a textureless room); shifted by room_texture_offset_mm so that images can see
  // different rooms.
  bool room_plain = false;
  Eigen::Vector3d room_texture_offset_mm = Eigen::Vector3d::Zero();
  // The mount's posts (the model's `mount:`): matte, self-lit grey (dark standoffs or light ones).
  double post_grey = 0.25;
  bool draw_mirrors = true;   // false: markers seen directly (a pinhole-only check)
};

// The complete .pov text for the rig and content at the given image size.
std::string PovSceneText(const RigParams& rig, const SceneContent& content);

struct RenderOptions {
  int width = 0, height = 0;   // 0: the rig's image size
  bool antialias = true;       // adaptive supersampling (+A0.0 +AM2 +R3)
  int antialias_depth = 3;
  // Optional sub-window in pixels [col0, col1) x [row0, row1) (0 = whole image): POV-Ray renders
  // only it, the rest of the PNG stays black.
  int col0 = 0, col1 = 0, row0 = 0, row1 = 0;
  int threads = 0;             // 0: POV-Ray's default
  int bits = 8;                // PNG bits per channel (linear: File_Gamma 1.0); 16 for camera effects
};

// Writes the scene next to out_png (same name, .pov) and runs `povray`; returns false and sets
// *error (with POV-Ray's last lines) on failure.
bool RenderScene(const std::string& pov_text, const std::string& out_png,
                 const RenderOptions& options, std::string* error);

}  // namespace omni::synthetic
