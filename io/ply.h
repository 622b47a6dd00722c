// Point clouds as PLY (docs/design.md, Conventions): x, y, z in mm in the camera frame C, colour, and each
// point's standard deviation sigma_mm (the square root of the largest eigenvalue of its 3x3
// covariance, [uncertainty_propagation]). Written atomically (file_util.h).
//
//   ply
//   format binary_little_endian 1.0      (or ascii 1.0)
//   comment omnistereo point cloud, frame C, mm
//   element vertex N
//   property float x / y / z
//   property uchar red / green / blue
//   property float sigma_mm
//   end_header
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace omni::io {

struct PlyPoint {
  float x = 0, y = 0, z = 0;  // mm, C
  std::uint8_t red = 0, green = 0, blue = 0;
  float sigma_mm = 0;
};

// Throws std::runtime_error if the file cannot be written (nothing is left behind then).
void WritePlyFile(const std::string& path, const std::vector<PlyPoint>& points,
                  bool binary = true);

// Reads a file written by WritePlyFile (either encoding); throws InputError naming the file and
// what was expected.
std::vector<PlyPoint> ReadPlyFile(const std::string& path);

}  // namespace omni::io
