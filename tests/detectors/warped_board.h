// Test scaffolding for single-mirror detection (single_mirror_detect_test, chessboard_passes_test):
// two misaligned single-mirror rigs and a chessboard warped into the raw image through the model
// (each raw pixel back-projected by RigModel::Unproject onto the board's plane, 3 x 3 samples
// per pixel: an oracle independent of the detector's views and forward projection).
#pragma once

#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "model/central_mirror.h"
#include "model/rig_model.h"
#include "model/target.h"
#include "synthetic/scene.h"

namespace omni::detectors::testing {

inline RigParams Misaligned(RigParams rig) {
  rig.mirror1_pose = {0.004, -0.003, 0.3, -0.2, 0.4};  // rx, ry (rad), tx, ty, tz (mm)
  return rig;
}

inline RigParams Parabolic() {
  return Misaligned(MakeSingleRig(Conic<double>{30.0, -1.0}, LensKind::kTelecentric, 60, 30, 4.5,
                                  Pinhole<double>{11.77, 11.77, 641.5, 521.2, 0}, 1280, 1024));
}

inline RigParams Hyperbolic() {
  CentralMirror central;  // the camera at the hyperboloid's far focus
  central.mirror = Conic<double>{20.0, -2.2};
  central.lens = LensKind::kPerspective;
  central.focal_px = 800;
  return Misaligned(MakeSingleRig(central.mirror, central.lens, central.CameraBelowVertexMm(), 30, 5,
                                  Pinhole<double>{800, 800, 640, 480, 0}, 1280, 960));
}

// A chessboard placed by `place`, warped into the raw image: grey `surround` around the sheet,
// its squares `dark` / `light` (the sheet's margin `light`). Into `raw` when given (another
// board's image: only this board's pixels are written), else a new image.
inline cv::Mat WarpBoard(const RigModel& model, const TargetSpec& spec, const synthetic::Placement& place,
                         int dark = 30, int light = 220, cv::Mat raw = cv::Mat(), int surround = 90) {
  const RigParams& rig = model.params();
  if (raw.empty()) raw = cv::Mat(rig.image_height, rig.image_width, CV_8U, cv::Scalar(surround));
  const Eigen::Vector3d origin = CornerInTarget(spec, 0);
  const Eigen::Vector3d ex = (CornerInTarget(spec, 1) - origin).normalized();
  const Eigen::Vector3d ey = (CornerInTarget(spec, spec.cols) - origin).normalized();
  const Eigen::Vector4d sheet = SheetBounds(spec);
  const Eigen::Matrix3d& R = place.cam_from_target_rotation;
  const Eigen::Vector3d& t = place.cam_from_target_translation;
  // The board's pixels: the box of its sheet's projected outline (sampled), plus a margin.
  cv::Rect box;
  for (int k = 0; k <= 40; ++k) {
    const double s = k / 40.0;
    for (const Eigen::Vector2d& q : {Eigen::Vector2d(sheet[0] + s * (sheet[2] - sheet[0]), sheet[1]),
                                    Eigen::Vector2d(sheet[0] + s * (sheet[2] - sheet[0]), sheet[3]),
                                    Eigen::Vector2d(sheet[0], sheet[1] + s * (sheet[3] - sheet[1])),
                                    Eigen::Vector2d(sheet[2], sheet[1] + s * (sheet[3] - sheet[1]))}) {
      const auto px = model.Project(R * Eigen::Vector3d(q.x(), q.y(), 0) + t, Mirror::kOne);
      if (px) box |= cv::Rect(static_cast<int>(px->x()) - 4, static_cast<int>(px->y()) - 4, 9, 9);
    }
  }
  box &= cv::Rect(0, 0, raw.cols, raw.rows);
  cv::Mat board(box.size(), CV_8U);
  for (int v = box.y; v < box.br().y; ++v) {
    for (int u = box.x; u < box.br().x; ++u) {
      double sum = 0;
      int n = 0;
      for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i) {
          const auto ray = model.Unproject(Eigen::Vector2d(u + (i - 1) / 3.0, v + (j - 1) / 3.0));
          ++n;
          if (!ray) {
            sum += surround;
            continue;
          }
          // The ray in the target frame, met with its plane z = 0.
          const Eigen::Vector3d o = R.transpose() * (ray->ray.origin - t);
          const Eigen::Vector3d d = R.transpose() * ray->ray.direction;
          const double s = -o.z() / d.z();
          if (!(s > 0)) {
            sum += surround;
            continue;
          }
          const Eigen::Vector3d p = o + s * d;
          if (p.x() < sheet[0] || p.x() > sheet[2] || p.y() < sheet[1] || p.y() > sheet[3]) {
            sum += surround;
            continue;
          }
          const double a = (p - origin).dot(ex) / spec.square_mm, b = (p - origin).dot(ey) / spec.square_mm;
          const bool in_squares = a > -1 && b > -1 && a < spec.cols && b < spec.rows;
          const bool dark_square = in_squares && (static_cast<int>(std::floor(a)) + static_cast<int>(std::floor(b))) % 2 == 0;
          sum += dark_square ? dark : light;
        }
      }
      board.at<uchar>(v - box.y, u - box.x) = static_cast<uchar>(std::lround(sum / n));
    }
  }
  // Blurred within its box (the surround beyond it is flat), so another board's pixels stay.
  cv::GaussianBlur(board, board, cv::Size(0, 0), 0.6, 0, cv::BORDER_REPLICATE);
  board.copyTo(raw(box));
  return raw;
}

}  // namespace omni::detectors::testing
