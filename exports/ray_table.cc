#include "exports/ray_table.h"

#include <limits>

#include <opencv2/core.hpp>

#include "stereo/sparse_triangulation.h"


namespace omni::exports {

NpyArray RayTable(const RigModel& model, ReferenceBody frame, DType dtype) {
  const int w = model.params().image_width, h = model.params().image_height;
  // The output frame from C (C itself, or mirror 1's body), as triangulate's.
  const Pose<double> out_from_cam =
      stereo::FramesOf(model.params(), frame, nullptr).out_from_cam;
  NpyArray table;
  table.name = "rays";
  table.dtype = dtype;
  const int rings = model.params().Paths();
  table.shape = {rings, h, w, 6};
  const size_t n = static_cast<size_t>(rings) * h * w * 6;
  std::vector<double> values(n, std::numeric_limits<double>::quiet_NaN());
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      for (int u = 0; u < w; ++u) {
        const auto ray = model.Unproject(Eigen::Vector2d(u, v));
        if (!ray) continue;
        const int ring = ray->mirror == Mirror::kOne ? 0 : 1;
        const Eigen::Vector3d origin = out_from_cam * ray->ray.origin;
        const Eigen::Vector3d direction = out_from_cam.rotation * ray->ray.direction;
        double* entry = &values[((static_cast<size_t>(ring) * h + v) * w + u) * 6];
        for (int k = 0; k < 3; ++k) {
          entry[k] = origin[k];
          entry[3 + k] = direction[k];
        }
      }
    }
  });
  if (dtype == DType::kFloat32) {
    table.f32.assign(values.begin(), values.end());
  } else {
    table.f64 = std::move(values);
  }
  return table;
}

}  // namespace omni::exports
