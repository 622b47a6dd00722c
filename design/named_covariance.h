// A model file's calibration covariance looked up by parameter name (rig.calibration's
// parameters, e.g. mirror1.tx): the sigma and correlations of linear combinations of named
// parameters, for the tolerance checks' first-order propagation.
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "model/rig_params.h"

namespace omni::design {

class NamedCovariance {
 public:
  explicit NamedCovariance(const RigParams& rig) {
    if (!rig.calibration) return;
    const CalibrationInfo& c = *rig.calibration;
    const size_t n = c.parameters.size();
    if (c.covariance.size() != n * n) return;
    for (size_t i = 0; i < n; ++i) index_[c.parameters[i]] = static_cast<int>(i);
    cov_ = &c.covariance;
    n_ = static_cast<int>(n);
  }
  bool Has(const std::vector<std::string>& names) const {
    if (!cov_) return false;
    return std::all_of(names.begin(), names.end(),
                       [&](const std::string& s) { return index_.count(s) > 0; });
  }
  // The covariance of two named parameters (Has both).
  double At(const std::string& a, const std::string& b) const {
    return (*cov_)[index_.at(a) * n_ + index_.at(b)];
  }
  // sigma of g . x over the named parameters.
  double Sigma(const std::vector<std::string>& names, const std::vector<double>& g) const {
    double var = 0;
    for (size_t a = 0; a < names.size(); ++a) {
      for (size_t b = 0; b < names.size(); ++b) var += g[a] * g[b] * At(names[a], names[b]);
    }
    return std::sqrt(std::max(0.0, var));
  }
  // The correlation of two named parameters (0 when either is missing or has no variance).
  double Correlation(const std::string& a, const std::string& b) const {
    if (!Has({a, b})) return 0;
    const double scale = std::sqrt(At(a, a) * At(b, b));
    return scale > 0 ? At(a, b) / scale : 0;
  }
  // The correlation of g . x (over `names`, all present) with the parameter `other` (0 if it is
  // missing or either has no variance).
  double Correlation(const std::vector<std::string>& names, const std::vector<double>& g,
                     const std::string& other) const {
    if (!Has({other})) return 0;
    double cov = 0;
    for (size_t a = 0; a < names.size(); ++a) cov += g[a] * At(names[a], other);
    const double scale = Sigma(names, g) * std::sqrt(At(other, other));
    return scale > 0 ? cov / scale : 0;
  }

 private:
  std::map<std::string, int> index_;
  const std::vector<double>* cov_ = nullptr;
  int n_ = 0;
};

}  // namespace omni::design
