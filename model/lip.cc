#include "model/lip.h"

#include <cmath>

namespace omni {
namespace {

struct NamedPaint {
  const char* name;
  double r, g, b;  // linear reflectance
};

// Matte paints' reflectances (linear), roughly as a colour chart measures them.
constexpr NamedPaint kPaints[] = {
    {"blue", 0, 0, 1},           {"red", 1, 0, 0},
    {"navy", 0.02, 0.03, 0.12},  {"matte_red", 0.45, 0.04, 0.03},
    {"green", 0.05, 0.32, 0.07}, {"orange", 0.75, 0.22, 0.02},
    {"yellow", 0.72, 0.58, 0.03}, {"white", 0.85, 0.85, 0.85},
    {"grey", 0.2, 0.2, 0.2},     {"black", 0.03, 0.03, 0.03},
};

double LinearFromSrgb(double x) {
  return x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4);
}

int HexDigit(char ch) {
  if (ch >= '0' && ch <= '9') return ch - '0';
  if (ch >= 'a' && ch <= 'f') return ch - 'a' + 10;
  if (ch >= 'A' && ch <= 'F') return ch - 'A' + 10;
  return -1;
}

}  // namespace

std::optional<Eigen::Vector3d> LipPaintRgb(const std::string& color) {
  for (const NamedPaint& p : kPaints) {
    if (color == p.name) return Eigen::Vector3d(p.r, p.g, p.b);
  }
  if (color.size() != 7 || color[0] != '#') return std::nullopt;
  Eigen::Vector3d rgb;
  for (int k = 0; k < 3; ++k) {
    const int hi = HexDigit(color[1 + 2 * k]), lo = HexDigit(color[2 + 2 * k]);
    if (hi < 0 || lo < 0) return std::nullopt;
    rgb[k] = LinearFromSrgb((16 * hi + lo) / 255.0);
  }
  return rgb;
}

Eigen::Vector3d LipPaintOf(const std::string& color, Mirror owner) {
  return LipPaintRgb(color).value_or(owner == Mirror::kOne ? Eigen::Vector3d(0, 0, 1)
                                                           : Eigen::Vector3d(1, 0, 0));
}

std::string LipPaintChoices() {
  std::string out;
  for (const NamedPaint& p : kPaints) out += std::string(p.name) + ", ";
  return out + "or \"#rrggbb\" (sRGB)";
}

const Lip& LipOf(const RigParams& rig, LipPath path) {
  return LipOwner(path) == Mirror::kOne ? rig.lip1 : rig.lip2;
}

std::optional<Eigen::Vector2d> ProjectLipPoint(const RigModel& model, LipPath path,
                                               LipCircle circle, double phi,
                                               double* disc_margin_mm) {
  const RigParams& rig = model.params();
  const Lip& lip = LipOf(rig, path);
  const double radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
  Eigen::Vector2d pixel;
  if (!ProjectLipPoint(RigBlocksOf(rig), model.fixed(), path, radius, lip.z, phi, &pixel,
                       disc_margin_mm) ||
      !pixel.allFinite()) {
    return std::nullopt;
  }
  return pixel;
}

namespace {

// Distance of a pixel to a curve pixel(phi), by a coarse-to-fine scan of phi from the pixel's own
// azimuth about the principal point.
template <typename Curve>
double DistanceToCurve(const RigParams& rig, const Curve& curve, const Eigen::Vector2d& pixel,
                       Eigen::Vector2d* nearest, double* nearest_phi) {
  double phi = std::atan2(pixel.y() - rig.camera[kCy], pixel.x() - rig.camera[kCx]);
  double best = 1e9;
  for (double step : {1e-2, 5e-4, 2e-5, 1e-6}) {
    double best_phi = phi;
    for (int k = -40; k <= 40; ++k) {
      Eigen::Vector2d q;
      if (curve(phi + k * step, &q) && q.allFinite() && (q - pixel).norm() < best) {
        best = (q - pixel).norm();
        best_phi = phi + k * step;
        if (nearest) *nearest = q;
      }
    }
    phi = best_phi;
  }
  if (nearest_phi) *nearest_phi = phi;
  return best;
}

}  // namespace

double DistanceToLipCircleImage(const RigModel& model, LipPath path, LipCircle circle,
                                const Eigen::Vector2d& pixel, Eigen::Vector2d* nearest) {
  return DistanceToCurve(
      model.params(),
      [&](double phi, Eigen::Vector2d* q) {
        const auto p = ProjectLipPoint(model, path, circle, phi);
        if (p) *q = *p;
        return p.has_value();
      },
      pixel, nearest, nullptr);
}

double DistanceToLipEdgeImage(const RigModel& model, LipPath path, LipCircle circle,
                              const Eigen::Vector2d& pixel, Eigen::Vector2d* nearest,
                              LipBound* bound, double* phi_out) {
  const RigParams& rig = model.params();
  const Lip& lip = LipOf(rig, path);
  const double radius = circle == LipCircle::kInner ? lip.r_inner : lip.r_outer;
  const RigBlocks<double> blocks = RigBlocksOf(rig);
  auto curve = [&](double phi, Eigen::Vector2d* q) {
    return ProjectLipEdge(blocks, model.fixed(), path, radius, lip.z, phi, model.fixed().r_ref, q);
  };
  double phi = 0;
  const double d = DistanceToCurve(rig, curve, pixel, nearest, &phi);
  if (phi_out) *phi_out = phi;
  if (bound && d < 1e8) {
    Eigen::Vector2d q;
    ProjectLipEdge(blocks, model.fixed(), path, radius, lip.z, phi, model.fixed().r_ref, &q,
                   bound);
  }
  return d;
}

}  // namespace omni
