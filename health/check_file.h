// The check's result as a file, `omnistereo-check/1` (what `omnistereo check --out` writes):
// the verdict and its reason, the evidence's counts and rms, the statistic with its degrees of
// freedom, each group's fitted move with its sigma (internal units: drift.h), and the residual
// bins (kind, azimuth, count, mean, standard error).
#pragma once

#include <string>

#include "health/check.h"

namespace omni::health {

// `model`: the stored model's path, written as given.
std::string CheckResultYaml(const CheckResult& r, const std::string& model);

}  // namespace omni::health
