#include "model/target.h"

namespace omni {

const char* TargetTypeName(TargetType type) {
  switch (type) {
    case TargetType::kChessboard: return "chessboard";
    case TargetType::kAprilTagGrid: return "apriltag_grid";
    case TargetType::kKalibrAprilGrid: return "kalibr_aprilgrid";
  }
  return "?";
}

std::string TargetName(const TargetSpec& spec) {
  std::string name = std::string(TargetTypeName(spec.type)) + " " + std::to_string(spec.rows) +
                     "x" + std::to_string(spec.cols);
  if (spec.type != TargetType::kChessboard) {
    name += " ids " + std::to_string(spec.first_id) + "-" +
            std::to_string(spec.first_id + spec.rows * spec.cols - 1);
  }
  return name;
}

bool ParseTargetType(const std::string& name, TargetType* type) {
  for (TargetType t : {TargetType::kChessboard, TargetType::kAprilTagGrid,
                       TargetType::kKalibrAprilGrid}) {
    if (name == TargetTypeName(t)) {
      *type = t;
      return true;
    }
  }
  return false;
}

int CornerCount(const TargetSpec& spec) {
  return spec.type == TargetType::kChessboard ? spec.rows * spec.cols : 4 * spec.rows * spec.cols;
}

std::vector<int> CornerIds(const TargetSpec& spec) {
  std::vector<int> ids;
  ids.reserve(CornerCount(spec));
  if (spec.type == TargetType::kChessboard) {
    for (int i = 0; i < spec.rows * spec.cols; ++i) ids.push_back(i);
  } else {
    for (int t = 0; t < spec.rows * spec.cols; ++t) {
      for (int k = 0; k < 4; ++k) ids.push_back(4 * (spec.first_id + t) + k);
    }
  }
  return ids;
}

bool HasCorner(const TargetSpec& spec, int id) {
  if (id < 0) return false;
  if (spec.type == TargetType::kChessboard) return id < spec.rows * spec.cols;
  int row, col;
  return TagCell(spec, id / 4, &row, &col);
}

double TagPitch(const TargetSpec& spec) { return (1.0 + spec.spacing) * spec.tag_size_mm; }

bool TagCell(const TargetSpec& spec, int tag_id, int* row_from_top, int* col) {
  const int index = tag_id - spec.first_id;
  if (spec.type == TargetType::kChessboard || index < 0 || index >= spec.rows * spec.cols) {
    return false;
  }
  const int r = index / spec.cols;
  *col = index % spec.cols;
  *row_from_top = spec.type == TargetType::kKalibrAprilGrid ? spec.rows - 1 - r : r;
  return true;
}

int TagIdAt(const TargetSpec& spec, int row_from_top, int col) {
  const int r = spec.type == TargetType::kKalibrAprilGrid ? spec.rows - 1 - row_from_top
                                                          : row_from_top;
  return spec.first_id + r * spec.cols + col;
}

Eigen::Vector3d CornerInTarget(const TargetSpec& spec, int id) {
  if (spec.type == TargetType::kChessboard) {
    const int row = id / spec.cols, col = id % spec.cols;
    return Eigen::Vector3d(col * spec.square_mm, row * spec.square_mm, 0.0);
  }
  int row = 0, col = 0;
  TagCell(spec, id / 4, &row, &col);
  const double pitch = TagPitch(spec), s = spec.tag_size_mm;
  const double x0 = col * pitch, y0 = row * pitch;  // the tag's top-left outer corner
  switch (id % 4) {
    case 0: return Eigen::Vector3d(x0, y0 + s, 0.0);      // bottom-left
    case 1: return Eigen::Vector3d(x0 + s, y0 + s, 0.0);  // bottom-right
    case 2: return Eigen::Vector3d(x0 + s, y0, 0.0);      // top-right
    default: return Eigen::Vector3d(x0, y0, 0.0);         // top-left
  }
}

Eigen::Vector4d SheetBounds(const TargetSpec& spec) {
  if (spec.type == TargetType::kChessboard) {
    const double sq = spec.square_mm;
    return Eigen::Vector4d(-2 * sq, -2 * sq, (spec.cols + 1) * sq, (spec.rows + 1) * sq);
  }
  const double pitch = TagPitch(spec), s = spec.tag_size_mm;
  const double bits = spec.type == TargetType::kKalibrAprilGrid ? 10.0 : 8.0;
  const double margin = spec.spacing * s + s / bits;
  return Eigen::Vector4d(-margin, -margin, (spec.cols - 1) * pitch + s + margin,
                         (spec.rows - 1) * pitch + s + margin);
}

}  // namespace omni
