// The panorama maps export: the cv::remap look-up tables of both rings' panoramas,
// the same ones `panorama` and `depth` use (stereo/panorama.h), with the tables that turn
// a panorama row into an elevation and a column into an azimuth, so that any stereo matcher can
// run on the rectified pair (epipolar lines are the panorama columns).
//
// Members of the .npz (float32 unless said):
//   ring1_map_x, ring1_map_y, ring2_map_x, ring2_map_y  (H, W): raw-image pixel of each panorama
//       pixel, -1 where the ring does not see it: cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR)
//   elevation_rad (H,), azimuth_rad (W,)  float64: of each row / column [elevation_inference_...],
//       [azimuth_inference_from_column_in_panoramic_image]
//   viewpoints_mm (2, 3) float64: F1, F2 in C; cam_from_cylinder (3, 3) float64: columns x, y and
//       the cylinder axis in C; radius_mm (1,) float64: the cylinder's radius (the LUTs are exact
//       for scene points at that range from each viewpoint).
// A single-mirror rig has one ring: ring1_map_x/y alone, viewpoints_mm (1, 3) (its mirror's near
// focus; the cylinder's axis is the mirror's).
#pragma once

#include <vector>

#include "exports/npy.h"
#include "model/rig_model.h"
#include "stereo/panorama.h"

namespace omni::exports {

std::vector<NpyArray> PanoramaMaps(const RigModel& model, const stereo::PanoramaOptions& options);

}  // namespace omni::exports
