// What `export --format kalibr|basalt` says of its central fits (central_fit.h): the residual per
// ring and distance, and both rings' residual maps as one image.
#pragma once

#include <vector>
#include <string>

#include <opencv2/core.hpp>

#include "exports/central_fit.h"

namespace omni::exports {

// The rings' residual maps in one CV_32F image (0 where neither ring sees), *seen (CV_8U) 255
// where one does, *max_px the larger ring maximum (0 when none).
cv::Mat BothResidualMaps(const std::vector<CentralRing>& rings, cv::Mat* seen, double* max_px);

// One line per ring and distance, newline-terminated: "  ring R at D m: RMS x px, max y px over
// N pixels" (and when some were not projectable).
std::string ResidualLines(const std::vector<CentralRing>& rings);

}  // namespace omni::exports
