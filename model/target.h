// Calibration targets: their kinds, and where each corner lies in the target's own frame.
//
// Target frame T (all kinds): the printed face is the plane z = 0 and faces -z (a camera looking
// along +z sees it, as in OpenCV); seen from the printed side x runs right and y runs DOWN; the
// origin is the first corner (chessboard) or the top-left outer corner of the top-left tag (tag
// grids). Corner ids are the detections file's (tests/data/detections_example.yaml):
//   chessboard:            id = row * cols + col over INNER corners, row 0 at the top;
//   apriltag_grid/kalibr:  id = 4 * tag_id + k, k = 0..3 the tag's outer black corners
//                          counter-clockwise as seen from the printed side, starting bottom-left
//                          (k=0 bottom-left, 1 bottom-right, 2 top-right, 3 top-left).
// Tag layout: `tag_size` is the side of the tag's outer black square; neighbouring tags are
// separated by a gap of spacing * tag_size.
//   apriltag_grid:    tag36h11 with libapriltag's 1-bit black border; ids first_id + r*cols + c
//                     row-major from the TOP-left (r = 0 is the top row); white gaps.
//   kalibr_aprilgrid: Kalibr's AprilGrid as kalibr_create_target_pdf prints it: tag_size is the
//                     whole tag, 10 bits of tag_size/10 (6x6 tag36h11 data bits in a 2-bit black
//                     border, no white border of its own); a black square of side gap at each
//                     tag's four diagonal corners, i.e. at all (rows+1) x (cols+1) crossings of
//                     the gaps including the outer frame; ids first_id + r*cols + c row-major
//                     from the BOTTOM-left (Kalibr's order; r = 0 is the bottom row). Kalibr's
//                     own frame has y up from tag 0's bottom-left corner; ids and k are the same.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace omni {

enum class TargetType { kChessboard, kAprilTagGrid, kKalibrAprilGrid };

struct TargetSpec {
  TargetType type = TargetType::kChessboard;
  int rows = 6, cols = 8;    // chessboard: inner corners; tag grids: tags
  double square_mm = 40.0;   // chessboard square side
  double tag_size_mm = 0.0;  // tag grids: outer black square side
  double spacing = 0.3;      // tag grids: gap / tag_size
  int first_id = 0;          // tag grids: id of the first tag
  std::string family = "tag36h11";
};

// A chessboard of rows x cols inner corners and squares of square_mm.
inline TargetSpec ChessboardSpec(int rows, int cols, double square_mm) {
  TargetSpec t;
  t.type = TargetType::kChessboard;
  t.rows = rows;
  t.cols = cols;
  t.square_mm = square_mm;
  return t;
}

// "chessboard", "apriltag_grid", "kalibr_aprilgrid".
const char* TargetTypeName(TargetType type);
// A target's name for people: "chessboard 5x6", "apriltag_grid 5x5 ids 0-24",
// "kalibr_aprilgrid 2x3 ids 50-55". Distinct for a session's targets as far as the detectors can
// tell them apart (chessboards by rows x cols, tag grids by their ids).
std::string TargetName(const TargetSpec& spec);
// Parses a type name; false if unknown.
bool ParseTargetType(const std::string& name, TargetType* type);

// Every corner id of the target, ascending.
std::vector<int> CornerIds(const TargetSpec& spec);
int CornerCount(const TargetSpec& spec);
bool HasCorner(const TargetSpec& spec, int id);

// The corner's point in the target frame (z = 0). `id` must satisfy HasCorner.
Eigen::Vector3d CornerInTarget(const TargetSpec& spec, int id);

// Tag grids: the tag's grid cell (row from the top, col from the left) for an absolute tag id;
// false if the id is not on this target.
bool TagCell(const TargetSpec& spec, int tag_id, int* row_from_top, int* col);
// Tag grids: the absolute tag id at a cell (row from the top).
int TagIdAt(const TargetSpec& spec, int row_from_top, int col);
// Tag grids: pitch between neighbouring tags' origins, (1 + spacing) * tag_size.
double TagPitch(const TargetSpec& spec);

// The printed sheet's rectangle in the target frame (x0, y0, x1, y1) including the white quiet
// zone around the pattern (one square for chessboards, one gap + 1 tag bit for tag grids).
Eigen::Vector4d SheetBounds(const TargetSpec& spec);

}  // namespace omni
