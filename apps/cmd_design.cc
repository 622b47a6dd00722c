// omnistereo design --config CONFIG.yaml [--out MODEL.yaml] [--curves_out DIR]
// Maximises the baseline [optimization_of_baseline] under the config's constraints, prints theta*
// and every by-product, writes the ideal model file and, if asked, the sensitivity curves.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "design/design_config.h"
#include "design/optimizer.h"
#include "design/sensitivity.h"
#include "io/model_file.h"
#include "model/rig_params.h"

DEFINE_string(curves_out, "", "folder for the sensitivity curves of the paper's section 5.2 (CSV)");

namespace omni::apps {
namespace {

constexpr double kDeg = 180.0 / M_PI;

void PrintReport(const design::OptimizerResult& result, const design::DesignConfig& config) {
  const design::DesignEvaluation& e = result.best;
  const DesignParams& t = e.theta;
  std::printf("status: %s (%s), %d evaluations, best start #%d\n\n", ToString(result.status),
              result.message.c_str(), result.evaluations, result.best_start);
  std::printf("theta*                      \n");
  std::printf("  c1                 %10.4f mm\n", t.c1);
  std::printf("  c2                 %10.4f mm\n", t.c2);
  std::printf("  k1                 %10.5f\n", t.k1);
  std::printf("  k2                 %10.5f    (k2/k1 = %.5f)\n", t.k2, t.k2 / t.k1);
  std::printf("  d                  %10.4f mm\n", t.d);
  std::printf("  r_sys              %10.4f mm\n", t.r_sys);
  std::printf("by-products\n");
  std::printf("  baseline b         %10.4f mm\n", e.baseline);
  std::printf("  r_ref              %10.4f mm   (needed by mirror 2: %.4f mm)\n", e.r_ref,
              e.r_ref_needed);
  std::printf("  r_cam              %10.4f mm\n", e.r_cam);
  std::printf("  h_sys              %10.4f mm   (z_max %.4f, z_min %.4f)\n", e.size.h_sys,
              e.size.z_max, e.size.z_min);
  std::printf("  z0_2 - a2          %10.4f mm\n", e.vertex_offset2);
  std::printf("  mass (authors' W)  %10.2f g\n", e.size.m_authors_g);
  std::printf("  mass m_sys         %10.2f g    (mirrors %.2f, tube %.2f, camera %.2f)\n",
              e.size.m_sys_g, e.size.m_mirrors_g, e.size.m_tube_g, e.size.m_cam_g);
  std::printf("  theta_1,max        %10.4f deg\n", e.fov.theta1_max * kDeg);
  std::printf("  theta_1,min        %10.4f deg\n", e.fov.theta1_min * kDeg);
  std::printf("  theta_2,max        %10.4f deg  (limited by r_cam)\n", e.fov.theta2_max * kDeg);
  std::printf("  theta_2,min        %10.4f deg\n", e.fov.theta2_min * kDeg);
  std::printf("  alpha_1, alpha_2   %10.4f, %.4f deg\n", e.fov.alpha1 * kDeg, e.fov.alpha2 * kDeg);
  std::printf("  alpha_sys          %10.4f deg\n", e.fov.alpha_sys * kDeg);
  std::printf("  alpha_SROI         %10.4f deg  [%.4f, %.4f]\n", e.fov.alpha_sroi * kDeg,
              e.fov.theta_sroi_min * kDeg, e.fov.theta_sroi_max * kDeg);
  std::printf("  P_ns,high (rho,z)  %10.2f, %.2f mm\n", e.sroi.high.x(), e.sroi.high.y());
  std::printf("  P_ns,mid  (rho,z)  %10.2f, %.2f mm\n", e.sroi.mid.x(), e.sroi.mid.y());
  std::printf("  P_ns,low  (rho,z)  %10.2f, %.2f mm\n", e.sroi.low.x(), e.sroi.low.y());
  std::printf("  alpha_cam bounds   %10.4f .. %.4f deg\n", e.camera_fov.lower * kDeg,
              e.camera_fov.upper * kDeg);
  std::printf("  chi = h_I1/h_I2    %10.4f\n", e.chi);
  std::printf("constraints (g <= 0, h = 0)\n");
  for (const auto& c : e.constraints) {
    std::printf("  %-3s %-40s %12.4g %-3s %s%s\n", c.name.c_str(), c.label.c_str(), c.value,
                c.unit.c_str(), c.satisfied ? "ok" : "VIOLATED", c.active ? ", active" : "");
  }
  std::printf("camera for the model: fx %.2f fy %.2f cx %.2f cy %.2f, image %dx%d\n",
              config.camera.fx, config.camera.fy, config.camera.cx, config.camera.cy,
              config.image_width, config.image_height);
}

// The three curves around the optimum: (a) about its c1 and theta_1,min, (b) about its c2, d,
// camera FOV lower bound and alpha_1, (c) over its stereo ROI.
void WriteCurves(const std::string& folder, const design::DesignEvaluation& e, double f_px) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec || !std::filesystem::is_directory(folder)) {
    throw std::runtime_error("--curves_out: cannot create the folder " + folder);
  }
  design::RsysVsKOptions a;
  a.c1 = e.theta.c1;
  a.theta1_min = e.fov.theta1_min;
  design::BaselineVsK1Options b;
  b.c2 = e.theta.c2;
  b.d = e.theta.d;
  b.alpha_cam = e.camera_fov.lower;
  b.alpha = {e.fov.alpha1 - 5 / kDeg, e.fov.alpha1, e.fov.alpha1 + 5 / kDeg};
  design::ResolutionVsElevationOptions c;
  c.theta = e.theta;
  c.f_px = f_px;
  c.theta_lo = e.fov.theta_sroi_min;
  c.theta_hi = e.fov.theta_sroi_max;
  c.k1 = {3.0, 4.0, e.theta.k1, 8.0, 11.0};
  c.k2 = {5.0, 7.0, e.theta.k2, 12.0, 14.0};
  const std::filesystem::path dir(folder);
  io::WriteFileAtomically((dir / "rsys_vs_k.csv").string(), design::ToCsv(design::RsysVsK(a)));
  io::WriteFileAtomically((dir / "baseline_vs_k1.csv").string(),
                          design::ToCsv(design::BaselineVsK1(b)));
  io::WriteFileAtomically((dir / "resolution_vs_elevation.csv").string(),
                          design::ToCsv(design::ResolutionVsElevation(c)));
  std::printf("curves: %s/{rsys_vs_k,baseline_vs_k1,resolution_vs_elevation}.csv\n",
              folder.c_str());
}

}  // namespace

int RunDesign() {
  if (FLAGS_config.empty()) {
    throw io::InputError("--config: expected the path of a design config (omnistereo-design/1)");
  }
  const design::DesignConfig config = design::ReadDesignConfig(FLAGS_config);
  const design::OptimizerResult result = design::OptimizeBaseline(config.options);
  if (result.status == design::OptimizerStatus::kInvalidOptions) {
    throw io::InputError(FLAGS_config + ": " + result.message);
  }
  if (result.status == design::OptimizerStatus::kInfeasible) {
    throw std::runtime_error(FLAGS_config + ": " + result.message +
                             " (relax the constraints or widen search_box)");
  }
  PrintReport(result, config);
  if (!FLAGS_curves_out.empty()) WriteCurves(FLAGS_curves_out, result.best, config.camera.fx);
  if (!FLAGS_out.empty()) {
    io::WriteModelFile(FLAGS_out, MakeIdealRig(result.best.theta, config.options.r_cam,
                                               config.camera, config.image_width,
                                               config.image_height));
    std::printf("model: %s\n", FLAGS_out.c_str());
  }
  return 0;
}

}  // namespace omni::apps
