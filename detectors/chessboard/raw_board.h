// A single mirror's chessboard that no view holds, found in the photo itself.
//
// The views (views.h) find a board where it fits one whole and looks like a board; on a single
// mirror a large board held close spans more azimuth than the views overlap, and a start model
// far from the mirror (an unknown shape started as a central hyperboloid) bends it beyond the
// grid check. OCamCalib's public sets show both: its Kaidan 360 set (640x480, 7x11 corners)
// gave 1 board in 17 photos through the views, its hyperbolic VMR set lost its closest board.
// There, and only in a photo where the views found no chessboard at all, OpenCV's sector-based
// finder (cv::findChessboardCornersSB) searches the photo as stored for each chessboard target.
//
// What is kept of its grid (the finder can take a board's outer border for a row: on VMR photo
// 6 it did, every id one row off): every corner must be an X-junction in the photo, its two
// opposite quadrants (0.3 squares along the grid's diagonals) darker than the other two by
// more than the pairs differ within (an L-corner of the border has one dark quadrant of four);
// one corner that is not refuses the board. Every corner must see the mirror through the model.
// Ids: the finder's grid relabelled to a proper board (the photo of a mirror is mirrored, so
// handedness comes from the model's rays: (sum of column steps x sum of row steps) . the mean
// ray > 0, as in a view), rows rising along +z_C where the board's symmetry leaves the choice.
// Then refined as every chessboard is (RefineBoardInRaw).
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "detectors/chessboard/chessboard_detector.h"

namespace omni::detectors {

// The board of `spec` in the photo (photo_grey: 8-bit grey as stored, for the finder;
// raw_grey: the grey the corners are refined in), nullopt where the finder finds none or the
// grid is refused. blur_px: the photo's blur (0: sharp).
std::optional<BoardDetection> FindBoardInPhoto(const cv::Mat& photo_grey, const cv::Mat& raw_grey,
                                               const RigModel& model, const TargetSpec& spec,
                                               int target, double blur_px,
                                               const ChessboardOptions& options);

// Whether four quadrant levels around a corner (++ +- -+ --, along its grid's diagonals) are an
// X-junction: the opposite pairs alike and apart from each other.
bool IsXJunction(double q_pp, double q_pm, double q_mp, double q_mm);

}  // namespace omni::detectors
