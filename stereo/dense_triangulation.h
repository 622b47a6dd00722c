// Triangulation of one dense match (dense_stereo.h) from tabulated rays, with its sigma.
//
// RayTable: a ring's exact ray at each panorama pixel of a band of rows, and its Jacobian w.r.t.
// the raw pixel (central differences of RigModel::Unproject, step 1e-3 px), built once per
// model. Everything that depends only on the panorama column and row is in it; a match then
// needs no ray tracing: ring 1's ray at (u, v), ring 2's at (u, v - d) interpolated linearly
// between rows (rays vary by ~1e-3 rad per row, so the interpolation error is ~1e-7 rad, far
// below the pixel noise).
//
// The point is the midpoint of the common perpendicular [midpoint_on_common_perpendicular]
// (MidpointOnCommonPerpendicular, triangulation.h: the one place of that maths), its covariance
// Sigma = sigma_px^2 A A^T, A = d point / d (u1, v1, u2, v2) [uncertainty_propagation], and the
// sigma is sqrt(largest eigenvalue of Sigma). Two ways to the same numbers:
//  - TriangulateMatchReference (the first implementation, kept as the oracle of the fast one):
//    Jets over the 12 ray coordinates, A = (d point / d rays) (d rays / d pixels), and Eigen's
//    closed-form 3x3 eigenvalues (acos / cos).
//  - TriangulateMatch (what DenseStereo runs): Jets over the 4 pixel coordinates seeded with the
//    ray Jacobians' columns (forward mode along d rays / d pixel: the same A by the chain rule,
//    a third of the work), and the largest eigenvalue by Newton's method on the characteristic
//    polynomial (LargestEigenvalue): no trigonometry. Same results to rounding.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "model/rig_model.h"

namespace omni::stereo {

// A ring's rays over panorama rows [row_begin, row_end), all columns.
struct RayTable {
  int width = 0, row_begin = 0, row_end = 0;
  std::vector<double> ray;             // 6 per pixel: origin, direction
  std::vector<float> jacobian;         // 12 per pixel, row-major 6 x 2 (by raw u, v)
  std::vector<std::uint8_t> valid;

  // Column-major: a column's rows are contiguous, as DenseStereo visits the matches.
  size_t Index(int u, int v) const {
    return static_cast<size_t>(u) * (row_end - row_begin) + (v - row_begin);
  }

  // Tabulates the rays of the LUT's raw pixels (map_x / map_y of panorama.h) that back-project
  // via `mirror` (parallel over rows).
  void Build(const RigModel& model, Mirror mirror, const cv::Mat& map_x, const cv::Mat& map_y,
             int begin, int end);

  // Ray and Jacobian at column u and (sub-pixel) row v, linear between rows; false outside the
  // band or where either row's entry is invalid.
  bool At(int u, double v, Eigen::Matrix<double, 6, 1>* r, Eigen::Matrix<double, 6, 2>* J) const;
};

struct MatchPoint {
  Eigen::Vector3d point_in_cam;  // mm
  double sigma_mm = 0;           // sqrt of the largest eigenvalue of the covariance
};

// The match of Xi_1 pixel (u, v) with Xi_2 (u, v - d) (dense_stereo.h's convention) through the
// tables. False if a ray is missing, the rays are parallel, or the point is behind either ray.
bool TriangulateMatch(const RayTable& ring1, const RayTable& ring2, int u, int v, double d,
                      double sigma_px, MatchPoint* out);
bool TriangulateMatchReference(const RayTable& ring1, const RayTable& ring2, int u, int v,
                               double d, double sigma_px, MatchPoint* out);

// Largest eigenvalue of a symmetric 3x3 matrix: Newton on the characteristic polynomial of
// m - (trace / 3) I from an upper bound of its roots, where it is increasing and convex, so the
// iterates fall monotonically onto the largest root; stops after a step below 1e-10 of it
// (then ~1e-20 off a simple root, ~1e-10 off a double one; an elongated covariance starts on it).
double LargestEigenvalue(const Eigen::Matrix3d& m);

}  // namespace omni::stereo
