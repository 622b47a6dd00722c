// What a real camera adds to POV-Ray's pinhole render: lens distortion (consistent with the
// model's RadTan: the output pixel u_d shows what the pinhole saw at K undistort(K^-1 u_d)) and
// Gaussian sensor noise. The resampling must not move edges: see image_effects.cc.
#pragma once

#include <opencv2/core.hpp>

#include "model/rig_params.h"

namespace omni::synthetic {

cv::Mat ApplyDistortion(const cv::Mat& pinhole_image, const RigParams& rig);
void AddNoise(cv::Mat* image, double sigma, unsigned seed);

}  // namespace omni::synthetic
