#include "exports/panorama_maps.h"

#include <string>

namespace omni::exports {
namespace {

NpyArray FromMat(const std::string& name, const cv::Mat& map) {
  NpyArray a;
  a.name = name;
  a.dtype = DType::kFloat32;
  a.shape = {map.rows, map.cols};
  a.f32.reserve(static_cast<size_t>(map.rows) * map.cols);
  for (int r = 0; r < map.rows; ++r) {
    const float* row = map.ptr<float>(r);
    a.f32.insert(a.f32.end(), row, row + map.cols);
  }
  return a;
}

NpyArray Doubles(const std::string& name, std::vector<int64_t> shape, std::vector<double> data) {
  NpyArray a;
  a.name = name;
  a.dtype = DType::kFloat64;
  a.shape = std::move(shape);
  a.f64 = std::move(data);
  return a;
}

}  // namespace

std::vector<NpyArray> PanoramaMaps(const RigModel& model, const stereo::PanoramaOptions& options) {
  const stereo::PanoramaLuts luts = stereo::BuildPanoramaLuts(model, options);
  const stereo::PanoramaGeometry& g = luts.geometry;
  std::vector<NpyArray> out;
  for (int m = 0; m < g.rings; ++m) {
    const std::string ring = "ring" + std::to_string(m + 1);
    out.push_back(FromMat(ring + "_map_x", luts.map_x[m]));
    out.push_back(FromMat(ring + "_map_y", luts.map_y[m]));
  }
  std::vector<double> elevation(g.height), azimuth(g.width);
  for (int v = 0; v < g.height; ++v) elevation[v] = g.Elevation(v);
  for (int u = 0; u < g.width; ++u) azimuth[u] = g.Azimuth(u);
  out.push_back(Doubles("elevation_rad", {g.height}, elevation));
  out.push_back(Doubles("azimuth_rad", {g.width}, azimuth));
  std::vector<double> viewpoints, axes;
  for (int m = 0; m < g.rings; ++m) {
    for (int k = 0; k < 3; ++k) viewpoints.push_back(g.viewpoint_in_cam[m][k]);
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) axes.push_back(g.cam_from_cylinder(r, c));
  }
  out.push_back(Doubles("viewpoints_mm", {g.rings, 3}, viewpoints));
  out.push_back(Doubles("cam_from_cylinder", {3, 3}, axes));
  out.push_back(Doubles("radius_mm", {1}, {g.radius_mm}));
  return out;
}

}  // namespace omni::exports
