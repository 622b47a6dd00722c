// The corner-window policy every detector uses: how large a window a corner is refined in, and
// how far from it its X-junction is probed, from the local size of its target where it is seen.
//
// Units: a window is a fraction of the local square (chessboard) or tag (Kalibr) side in the
// pixels of the image the corner is refined in (raw or view), so a board looks the same to the
// refinement at any image size; the pixel bounds are what a pixel grid needs (cornerSubPix
// wants at least a 5 x 5 window, the junction probe 1.5 px to step off the blurred edges), and
// the one bound that is not (the chessboard window's cap) is an angle of the camera's view
// (CameraPixelsPerDegree), not a pixel count of one image size.
#pragma once

#include "model/rig_params.h"

namespace omni::detectors {

// Raw image pixels per degree at the image centre: the camera's mean focal length (px / rad)
// times pi / 180 (25.3 px/deg for the big rig at 1280x960, 19.0 at 960x720, 51.3 at 2592x1944).
double CameraPixelsPerDegree(const RigParams& rig);

// A chessboard corner's cv::cornerSubPix half-window (raw px) from its local square side (raw
// px, the nearest grid neighbour): 0.55 squares, at least 2 px, and at most
// kChessboardMaxHalfDeg of the camera's view but never capped below kChessboardMinCapPx; 1
// (3 x 3) on squares under 3 px, where a 5 x 5 window spans the neighbouring corners.
// `camera_px_per_deg`: CameraPixelsPerDegree.
// The window averages the demosaicing's and the noise's errors over its edge pixels: the more
// of the four squares' edges it holds the better (0.55 squares; 0.7 reaches the next corners).
// The cap grows with the view's resolution (prototype_scene at 2592x1944, chessboards ring 1 /
// 2 mean 0.0224 / 0.0318 px with an 8 px cap, 0.0198 / 0.0311 with 16 px), and never holds
// fewer pixels than 8 px (at 960x720 a 6 px cap lost a corner and moved ring 1's mean 0.0321 ->
// 0.0323 px).
constexpr double kChessboardHalfSquares = 0.55;
constexpr double kChessboardMaxHalfDeg = 0.316;  // 8 px at 1280x960 on the big rig, 16 at 2592x1944
constexpr int kChessboardMinCapPx = 8;
int ChessboardHalfWindow(double square_side_px, double camera_px_per_deg);

// A Kalibr tag corner's saddle refinement (RefineSaddleCorner) half-window: 0.15 of the tag's
// side, in the pixels the side is measured in; within it lie the tag's corner and its corner
// square's, whose side is 0.3 tags (the grid's spacing).
int TagCornerHalfWindow(double tag_side_px);

// The offset from a Kalibr tag corner at which IsKalibrXJunction reads the four quadrants:
// 0.12 of the tag's side (inside the corner square), at least 1.5 px (off the blurred edges).
double XJunctionProbe(double tag_side_px);

}  // namespace omni::detectors
