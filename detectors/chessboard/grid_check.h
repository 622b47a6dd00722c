// The grid check of a board's refined corners (chessboard_detector.cc MakeBoard): they must lie
// on the board's image in the view, a homography of the target's grid, bent where the model is
// a start (ChessboardOptions::smooth_grid_correction) by a smooth cubic of the grid coordinates.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "detectors/chessboard/chessboard_detector.h"
#include "detectors/common/views.h"
#include "model/rig_model.h"

namespace omni::detectors {

// The homography's residuals over the board (`grid_in` -> `view_in`, in view px) fitted by a
// cubic in the grid coordinates (a quadratic with under 20 corners), added to its predictions of
// `grid`: what a smooth error of the model bends the board's image by (GridFitsBoard). Cubic:
// a single mirror's start model bends a large board near the rim by more than a quadratic
// takes (Mei's photo 1: 48 corners, residuals to 2.5 raw px after the quadratic, 45 kept of 48;
// all 48 within 0.5 px after the cubic). Left as it is with too few corners for the terms to be
// measured twice over.
void AddSmoothCorrection(const std::vector<cv::Point2f>& grid_in, const std::vector<cv::Point2f>& view_in,
                         const cv::Mat& h, const std::vector<cv::Point2f>& grid,
                         std::vector<cv::Point2f>* predicted);

// The refined corners of one board must lie on the board's image: in a view the board is a
// plane seen by a pinhole (a homography of the target's grid, exact to 0.01 px for the views'
// rays at 0.5-2 m, measured on ComputeTruth corners), and every corner must sit on its own grid
// point. The corner finders can return a grid in which some rows or columns are mis-ordered (on
// the inner ring's 2-3 px squares near 2 m: neighbouring ids swapped, each ~1 px from a true
// corner); such corners are a large fraction of a square off the grid's homography. Refined raw
// corners are taken back into the view (exact back-projection), a homography is fitted to them
// by RANSAC and the board is refused unless (nearly) all corners fit it: a detector that
// guesses gives wrong ids, which the calibration cannot tell from data. Single outliers in a
// board that otherwise fits are dropped. Returns false to refuse the whole board.
bool GridFitsBoard(const RingView& view, const RigModel& model, int cols,
                   const ChessboardOptions& options, BoardDetection* board);

}  // namespace omni::detectors
