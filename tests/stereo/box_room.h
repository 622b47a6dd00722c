// A box room with a smooth random texture, imaged by casting each raw pixel's exact ray
// (RigModel::Unproject) into the box: a scene whose surface is known exactly, for the dense
// stereo tests (dense_stereo_test.cc, dense_fast_path_test.cc).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "model/rig_model.h"

namespace omni::stereo {

struct Box {
  double half = 2500, floor = -1000, ceiling = 1500;  // mm in C (z up the rig's axis)

  // Distance from inside point p to the nearest face (negative outside).
  double DistanceToSurface(const Eigen::Vector3d& p) const {
    return std::min({half - std::abs(p.x()), half - std::abs(p.y()), p.z() - floor,
                     ceiling - p.z()});
  }
};

inline double Hash(int x, int y, int face) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 73856093u ^
                    static_cast<std::uint32_t>(y) * 19349663u ^
                    static_cast<std::uint32_t>(face) * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return (h & 0xffff) / 65535.0;
}

// Smooth value noise (smoothstep between lattice values), three octaves.
inline double Texture(double s, double t, int face) {
  double value = 0, weight = 0;
  for (double cell : {30.0, 70.0, 170.0}) {
    const double x = s / cell, y = t / cell;
    const int ix = static_cast<int>(std::floor(x)), iy = static_cast<int>(std::floor(y));
    double fx = x - ix, fy = y - iy;
    fx = fx * fx * (3 - 2 * fx);
    fy = fy * fy * (3 - 2 * fy);
    const double a = Hash(ix, iy, face), b = Hash(ix + 1, iy, face);
    const double c = Hash(ix, iy + 1, face), d = Hash(ix + 1, iy + 1, face);
    value += cell * ((a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy);
    weight += cell;
  }
  return value / weight;
}

// Where the ray hits the box from inside: false if it does not.
inline bool Hit(const Box& box, const Ray& ray, Eigen::Vector3d* point, int* face_out = nullptr) {
  double best_t = INFINITY;
  int face = -1;
  const double planes[6] = {box.half, -box.half, box.half, -box.half, box.ceiling, box.floor};
  for (int f = 0; f < 6; ++f) {
    const int axis = f / 2;
    if (std::abs(ray.direction[axis]) < 1e-12) continue;
    const double t = (planes[f] - ray.origin[axis]) / ray.direction[axis];
    if (t > 0 && t < best_t) best_t = t, face = f;
  }
  if (face < 0) return false;
  *point = ray.origin + best_t * ray.direction;
  if (face_out) *face_out = face;
  return true;
}

// Grey level of the box surface the ray hits.
inline double Shade(const Box& box, const Ray& ray) {
  Eigen::Vector3d p;
  int face = -1;
  if (!Hit(box, ray, &p, &face)) return 0;
  const int axis = face / 2;
  const double s = p[(axis + 1) % 3], t = p[(axis + 2) % 3];
  return 30 + 200 * Texture(s, t, face);
}

inline cv::Mat RenderBox(const RigModel& model, const Box& box) {
  const RigParams& rig = model.params();
  cv::Mat image(rig.image_height, rig.image_width, CV_8UC1, cv::Scalar(0));
  cv::parallel_for_(cv::Range(0, image.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      for (int u = 0; u < image.cols; ++u) {
        // 2x2 samples per pixel against aliasing.
        double sum = 0;
        int n = 0;
        for (double dv : {-0.25, 0.25}) {
          for (double du : {-0.25, 0.25}) {
            const auto ray = model.Unproject(Eigen::Vector2d(u + du, v + dv));
            if (!ray) continue;
            sum += Shade(box, ray->ray);
            ++n;
          }
        }
        image.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(n ? sum / n : 0);
      }
    }
  });
  cv::Mat bgr;
  cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace omni::stereo
