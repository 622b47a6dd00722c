#include "design/rig_body.h"

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "model/hyperboloid.h"
#include "model/rig_frames.h"
#include "model/rig_parameters.h"

namespace omni::design {
namespace {

// The quantities as one vector: mirror 2's decentre (2), tilt (2), spacing (1), the camera's
// decentre (2) and tilt (2).
constexpr int kQuantities = 9;
using QuantityVector = Eigen::Matrix<double, kQuantities, 1>;

QuantityVector AsVector(const RigBodyQuantities& q) {
  QuantityVector v;
  v << q.mirror2_decentre_mm, q.mirror2_tilt_rad, q.mirror2_spacing_mm, q.camera_decentre_mm,
      q.camera_tilt_rad;
  return v;
}

// The pose blocks' parameters (mirror 1's then mirror 2's), which the quantities depend on.
std::vector<const RigParameter*> PoseParameters() {
  std::vector<const RigParameter*> out;
  for (RigBlockId block : {kPose1Block, kPose2Block}) {
    const RigParameter* p = BlockParameters(block);
    for (int i = 0; i < kRigBlocks[block].size; ++i) out.push_back(&p[i]);
  }
  return out;
}

// d quantities / d parameter by central differences (steps: 1e-7 rad, 1e-6 mm).
Eigen::MatrixXd Jacobian(const RigParams& rig, const std::vector<const RigParameter*>& params) {
  Eigen::MatrixXd j(kQuantities, params.size());
  for (size_t i = 0; i < params.size(); ++i) {
    const double h = params[i]->unit == ParameterUnit::kRadian ? 1e-7 : 1e-6;
    RigParams plus = rig, minus = rig;
    *ParameterOf(&plus, params[i]->name) += h;
    *ParameterOf(&minus, params[i]->name) -= h;
    j.col(i) = (AsVector(RigBodyQuantitiesOf(plus)) - AsVector(RigBodyQuantitiesOf(minus))) / (2 * h);
  }
  return j;
}

struct Labelled {
  const char* name;
  const char* unit;
  int first, size;  // rows of the quantity vector
  double limit;
};

// A check of |rows| against its limit, with the first-order sigma over the covariance's
// parameters and (the camera's tilt) the strongest correlation with the principal point.
ToleranceCheck MakeCheck(const Labelled& l, const QuantityVector& q, const Eigen::MatrixXd& j,
                         const std::vector<const RigParameter*>& params,
                         const NamedCovariance& cov) {
  ToleranceCheck c;
  c.name = l.name;
  c.unit = l.unit;
  c.limit = l.limit;
  c.frame = "mirror1";
  const Eigen::VectorXd value = q.segment(l.first, l.size);
  c.value = value.norm();
  const std::string axes[2] = {".x", ".y"};
  for (int i = 0; i < l.size; ++i) {
    c.parameters.push_back(l.size == 1 ? std::string(l.name) : l.name + axes[i]);
    c.components.push_back(value(i));
  }
  std::vector<std::string> names;
  std::vector<int> columns;
  for (size_t k = 0; k < params.size(); ++k) {
    if (cov.Has({params[k]->name})) {
      names.push_back(params[k]->name);
      columns.push_back(static_cast<int>(k));
    }
  }
  if (names.empty()) return c;
  // The gradient of |value|; at the origin, the larger of the components' sigmas.
  auto gradient_of = [&](const Eigen::VectorXd& weights) {
    std::vector<double> g;
    for (int col : columns) g.push_back(weights.dot(j.block(l.first, col, l.size, 1).col(0)));
    return g;
  };
  std::vector<double> g;
  if (c.value > 1e-12) {
    g = gradient_of(value / c.value);
    c.sigma = cov.Sigma(names, g);
  } else {
    double best = -1;
    for (int i = 0; i < l.size; ++i) {
      const std::vector<double> gi = gradient_of(Eigen::VectorXd::Unit(l.size, i));
      const double s = cov.Sigma(names, gi);
      if (s > best) best = s, g = gi;
    }
    c.sigma = best;
  }
  // In the valley when one of its components is (as the camera-frame checks test each of
  // their parameters): the magnitude's own gradient mixes the components.
  c.gradient_names = names;
  c.gradient = g;
  for (int i = 0; i < l.size; ++i) {
    const std::vector<double> gi = gradient_of(Eigen::VectorXd::Unit(l.size, i));
    for (const RigParameter& p : RigParameterTable()) {
      if (p.valley != RotationValley::kPrincipalPoint) continue;
      const double r = cov.Correlation(names, gi, p.name);
      if (std::abs(r) > std::abs(c.valley_correlation)) {
        c.valley_correlation = r;
        c.valley_pair = c.parameters[i] + " ~ " + p.name;
      }
    }
  }
  return c;
}

}  // namespace

RigBodyQuantities RigBodyQuantitiesOf(const RigParams& rig) {
  const Pose<double> cam_from_m1 = PoseFromBlock(rig.mirror1_pose.data());
  const Pose<double> cam_from_m2 = PoseFromBlock(rig.mirror2_pose.data());
  const Pose<double> m1_from_cam = cam_from_m1.Inverse();
  const Mat3<double> m1_from_m2 = m1_from_cam.rotation * cam_from_m2.rotation;
  const double c2 = rig.mirror2_shape[kShapeC], k2 = rig.mirror2_shape[kShapeK];
  const double vertex2 = HyperboloidSheet<double>::Mirror2(c2, k2, rig.d).VertexZ();
  const Eigen::Vector3d vertex2_in_m1 = m1_from_cam * (cam_from_m2 * Eigen::Vector3d(0, 0, vertex2));
  const Eigen::Vector3d axis2_in_m1 = m1_from_m2 * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d camera_axis_in_m1 = m1_from_cam.rotation * Eigen::Vector3d::UnitZ();
  RigBodyQuantities q;
  q.mirror2_decentre_mm = vertex2_in_m1.head<2>();
  q.mirror2_tilt_rad = axis2_in_m1.head<2>();
  q.mirror2_spacing_mm = vertex2_in_m1.z() - vertex2;
  q.camera_decentre_mm = m1_from_cam.translation.head<2>();
  q.camera_tilt_rad = camera_axis_in_m1.head<2>();
  return q;
}

std::vector<ToleranceCheck> CheckRigBody(const RigParams& rig, const RigBodyTolerance& tolerance,
                                         const NamedCovariance& cov) {
  const std::vector<const RigParameter*> params = PoseParameters();
  const QuantityVector q = AsVector(RigBodyQuantitiesOf(rig));
  const Eigen::MatrixXd j = Jacobian(rig, params);
  const Labelled labelled[] = {
      {"mirror2.decentre_to_mirror1", "mm", 0, 2, tolerance.mirror2_decentre_mm},
      {"mirror2.tilt_to_mirror1", "rad", 2, 2, tolerance.mirror2_tilt_rad},
      {"mirror2.spacing", "mm", 4, 1, tolerance.mirror2_spacing_mm},
      {"camera.decentre_to_axis", "mm", 5, 2, tolerance.camera_decentre_mm},
      {"camera.tilt_to_axis", "rad", 7, 2, tolerance.camera_tilt_rad}};
  std::vector<ToleranceCheck> checks;
  for (const Labelled& l : labelled) {
    if (l.limit >= 0) checks.push_back(MakeCheck(l, q, j, params, cov));
  }
  return checks;
}

std::string RigBodyCorrection(const ToleranceCheck& c) {
  const bool deg = c.unit == "rad";
  const double k = deg ? 180.0 / M_PI : 1.0;
  const char* unit = deg ? "deg" : "mm";
  const double excess = c.value - c.limit;
  const std::string part = c.name.substr(0, c.name.find('.'));
  const std::string what = part == "camera" ? "the camera" : "mirror 2";
  char line[400];
  if (c.components.size() == 1) {
    const double v = c.components[0];
    std::snprintf(line, sizeof line,
                  "%s's vertex sits %+.3f mm along mirror 1's axis from the design's place, %.3f "
                  "beyond +-%.3f: move it %.3f mm %s the camera",
                  what.c_str(), v, excess, c.limit, excess, v > 0 ? "towards" : "away from");
    return line;
  }
  const double sx = c.value > 0 ? -excess * c.components[0] / c.value : 0;
  const double sy = c.value > 0 ? -excess * c.components[1] / c.value : 0;
  if (deg) {
    std::snprintf(line, sizeof line,
                  "%s's axis leans (%+.3f, %+.3f) deg against mirror 1's (x, y in mirror 1's "
                  "frame), |.| %.3f beyond %.3f by %.3f: tilt %s by (%+.3f, %+.3f) deg there",
                  what.c_str(), c.components[0] * k, c.components[1] * k, c.value * k,
                  c.limit * k, excess * k, what.c_str(), sx * k, sy * k);
  } else {
    std::snprintf(line, sizeof line,
                  "%s sits (%+.3f, %+.3f) mm off mirror 1's axis (x, y in mirror 1's frame), "
                  "|.| %.3f beyond %.3f by %.3f: move %s by (%+.3f, %+.3f) mm there, towards the "
                  "axis",
                  part == "camera" ? "the camera's centre" : "mirror 2's vertex", c.components[0],
                  c.components[1], c.value, c.limit, excess, what.c_str(), sx, sy);
  }
  (void)unit;
  return line;
}

}  // namespace omni::design
