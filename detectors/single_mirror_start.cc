#include "detectors/single_mirror_start.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "detectors/common/views.h"
#include "io/image_file.h"
#include "model/central_mirror.h"

namespace omni::detectors {
namespace {

template <typename... Args>
std::string Format(const char* format, Args... args) {
  char line[1024];
  std::snprintf(line, sizeof line, format, args...);
  return line;
}

constexpr double kDeg = 180 / M_PI;

// The conic constant the start takes for each kind (a hyperboloid's comes from its geometry).
double StartK(MirrorKnowledge kind) {
  return kind == MirrorKnowledge::kSpherical ? 0.0 : -1.0;
}

// Perspective lens, a hyperboloid with the camera at its far focus (central) and the rim in the
// near focus's plane: R = r and tan(alpha) = (e^2 - 1) / (2 e).
double HyperboloidRimAngle(double e) { return std::atan((e * e - 1) / (2 * e)); }

// The lens centre's distance below the vertex for the rim seen at alpha: r / tan(alpha) - sag.
std::optional<double> VertexDistance(double r, double K, double alpha) {
  const auto rim = RimConic(r, K, alpha);
  if (!rim) return std::nullopt;
  return r / std::tan(alpha) - rim->rim_sag;
}

// The rim angle whose conic of constant K puts the vertex d above the lens: bisection
// (the distance falls from infinity at alpha -> 0 to below zero towards 90 deg).
std::optional<double> RimAngleForDistance(double r, double K, double d) {
  double lo = 1e-6, hi = M_PI / 2 - 1e-6;
  auto f = [&](double a) {
    const auto v = VertexDistance(r, K, a);
    return v ? *v - d : -1.0;  // no conic: treat as too steep
  };
  if (!(f(lo) > 0) || !(f(hi) < 0)) return std::nullopt;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) > 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// The relative mismatch |a - b| / b.
double Mismatch(double a, double b) { return std::abs(a - b) / b; }

}  // namespace

bool ParseMirrorKnowledge(const std::string& name, MirrorKnowledge* kind) {
  for (MirrorKnowledge k : {MirrorKnowledge::kHyperbolic, MirrorKnowledge::kParabolic,
                            MirrorKnowledge::kSpherical, MirrorKnowledge::kUnknown}) {
    if (name == MirrorKnowledgeName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

const char* MirrorKnowledgeName(MirrorKnowledge kind) {
  switch (kind) {
    case MirrorKnowledge::kHyperbolic: return "hyperbolic";
    case MirrorKnowledge::kParabolic: return "parabolic";
    case MirrorKnowledge::kSpherical: return "spherical";
    case MirrorKnowledge::kUnknown: return "unknown";
  }
  return "";
}

std::string SingleMirrorKnowledge::Check() const {
  const bool telecentric = lens == LensKind::kTelecentric;
  if (!(mirror_diameter >= 0)) {
    return "mirror_diameter: expected the mirror rim's measured diameter in mm (> 0; 0: not "
           "measured): it sets the model's scale";
  }
  if (!(camera_distance >= 0)) return "camera_distance: expected a distance in mm (> 0)";
  if (!(focal_px >= 0)) return "focal_px: expected the lens's focal length in px (> 0)";
  if (!(magnification >= 0)) return "magnification: expected px per mm (> 0)";
  if (telecentric && mirror == MirrorKnowledge::kHyperbolic) {
    return "lens: a telecentric lens sees a hyperbolic mirror from infinity, where no "
           "hyperboloid is central and no such camera is built; a hyperboloid goes with a "
           "perspective lens at its far focus, a telecentric lens with a paraboloid";
  }
  if (telecentric && focal_px > 0) {
    return "focal_px: a telecentric lens has no focal length in px; give --magnification (px per "
           "mm: the lens's magnification over the pixel pitch)";
  }
  if (!telecentric && magnification > 0) {
    return "magnification: only for a telecentric lens; a perspective lens takes --focal_px";
  }
  if (!telecentric && mirror == MirrorKnowledge::kSpherical && camera_distance == 0 &&
      focal_px == 0) {
    return "camera_distance: a spherical mirror has no central configuration that places the "
           "camera; give the lens's rough distance to the mirror's vertex (mm) or --focal_px";
  }
  if ((unified_xi > 0) != (unified_gamma > 0) || unified_xi < 0 || unified_gamma < 0) {
    return "unified: expected XI,GAMMA_PX, both > 0 (a central fit's unified model)";
  }
  if (unified_xi > 0 && (mirror == MirrorKnowledge::kSpherical ||
                         (mirror == MirrorKnowledge::kParabolic && !telecentric))) {
    return std::string("unified: a unified model is a central camera, which a ") +
           MirrorKnowledgeName(mirror) + " mirror with a " + (telecentric ? "telecentric" : "perspective") +
           " lens is not";
  }
  if (unified_xi > 0 && focal_px > 0) {
    return "focal_px: the unified fit's gamma gives the focal length; give one or the other";
  }
  if (!(distance_tolerance > 0) || !(magnification_tolerance > 0)) {
    return "tolerance: expected > 0";
  }
  if (!(r_cam_fraction >= 0 && r_cam_fraction < 1)) return "r_cam_fraction: expected in [0, 1)";
  return "";
}

std::optional<RimConicResult> RimConic(double r, double K, double alpha) {
  // The slope dz/dr = sigma at the rim turns a ray at alpha from the axis to 90 deg; with
  // q = r / sigma the conic (1 + K) s^2 - 2 R s + r^2 = 0 and its slope r / (R - (1 + K) s) = sigma
  // leave (1 + K) s^2 + 2 q s - r^2 = 0 and R = q + (1 + K) s.
  const double sigma = alpha == 0 ? 1.0 : std::tan(M_PI / 4 - alpha / 2);  // exact when 0
  if (!(r > 0) || !(sigma > 0)) return std::nullopt;
  const double q = r / sigma;
  const double disc = q * q + (1 + K) * r * r;
  if (!(disc >= 0)) return std::nullopt;
  RimConicResult out;
  out.rim_sag = r * r / (q + std::sqrt(disc));
  out.conic = Conic<double>{q + (1 + K) * out.rim_sag, K};
  if (!(out.conic.R > 0) || !out.conic.Covers(r * r)) return std::nullopt;
  return out;
}

namespace {

// The session's estimate, priors and their comments.
void ChooseEstimate(const SingleMirrorKnowledge& know, SingleMirrorStart* out) {
  const double R = out->rig.mirror1_shape[kShapeC];
  out->estimate = {"camera", "distortion", "mirror1_shape", "mirror1_pose"};
  out->comments = {
      "estimate: camera (f and the principal point start from the rim), distortion (none at the",
      "start), mirror1_shape (R, K: the start's R assumes the rim reflects to the horizon; nobody",
      "measured it, so the photos refine it), mirror1_pose (the camera's offset and tilt against",
      "the mirror's axis: how far it sits from the focus, the non-central part)."};
  if (know.lens == LensKind::kTelecentric) {
    out->comments.push_back(
        "A telecentric lens: the calibration holds R (it trades with the magnification); the rim's "
        "diameter sets the scale.");
  }
  const bool declared = know.mirror == MirrorKnowledge::kParabolic ||
                        know.mirror == MirrorKnowledge::kSpherical;
  if (declared) {
    // The maker's kind held (sigma_k), R free in effect (a prior as wide as R itself, rounded:
    // a sigma need not be exact).
    const double sigma_r = std::max(1.0, std::round(R));
    out->priors.push_back({"mirror1_shape", ShapePrior{sigma_r, 0.01}});
    out->comments.push_back(Format(
        "priors: K held near %g (sigma 0.01: a %s mirror as made), R free in effect (sigma %g mm, "
        "its own size).",
        out->rig.mirror1_shape[kShapeK],
        know.mirror == MirrorKnowledge::kParabolic ? "parabolic" : "spherical", sigma_r));
  } else {
    out->comments.push_back(std::string("No prior on the shape: K is free (the mirror was "
                                        "declared ") + MirrorKnowledgeName(know.mirror) +
                            "), the photos decide the conic.");
  }
  out->comments.push_back("lips: true: the mirror's rim is measured in every photo (a circle of "
                          "the given diameter; calibrate leaves it out where the mirror's outer "
                          "zone looks back over it). false: the rim only placed the start.");
}

std::string ConicLine(const RigParams& rig) {
  const double K = rig.mirror1_shape[kShapeK];
  return Format("%s R %.3f mm, K %.4f", ConicKindName(KindOfConic(K)), rig.mirror1_shape[kShapeC], K);
}

// The start's conic constant and the rim's angle from the lens axis (perspective; telecentric 0)
// from what the builder knows, the diameter checked where two things are known. Adds the checks'
// and assumptions' lines; *why ("<field>: ...") where the diameter disagrees or no conic fits.
struct RimGeometry {
  double K = -1, alpha = 0;
};
std::optional<RimGeometry> ChooseRimGeometry(const SingleMirrorKnowledge& know, double rho,
                                             std::vector<std::string>* lines, std::string* why) {
  auto fail = [&](const std::string& text) {
    *why = text;
    return std::nullopt;
  };
  const double D = know.mirror_diameter, r = D / 2, given_d = know.camera_distance;
  // Perspective: the rim's angle from focal_px and the diameter place the lens; camera_distance
  // says where it is.
  auto distance_mismatch = [&](double implied) -> std::optional<std::string> {
    const double off = Mismatch(implied, given_d);
    const std::string text = Format(
        "the %g mm rim seen at %.2f px with --focal_px %g puts the lens %.1f mm from the mirror's "
        "vertex, --camera_distance says %g mm (off by %.0f%%, tolerance %.0f%%)",
        D, rho, know.focal_px, implied, given_d, 100 * off, 100 * know.distance_tolerance);
    if (off > know.distance_tolerance) {
      return "mirror_diameter: " + text +
             ": check the diameter (mm, across the rim), --focal_px and --camera_distance";
    }
    lines->push_back("diameter checked: " + text);
    return std::nullopt;
  };
  RimGeometry g{StartK(know.mirror), 0};
  if (know.lens == LensKind::kTelecentric) {
    if (know.magnification > 0) {
      const double m = rho / r, off = Mismatch(m, know.magnification);
      const std::string text = Format(
          "the %g mm rim seen at %.2f px is %.3f px per mm, --magnification says %g (off by "
          "%.1f%%, tolerance %.0f%%)",
          D, rho, m, know.magnification, 100 * off, 100 * know.magnification_tolerance);
      if (off > know.magnification_tolerance) {
        return fail("mirror_diameter: " + text + ": check the diameter (mm, across the rim) and "
                    "the magnification (the lens's over the pixel pitch in mm)");
      }
      lines->push_back("diameter checked: " + text);
    }
    return g;
  }
  if (know.mirror == MirrorKnowledge::kHyperbolic || know.mirror == MirrorKnowledge::kUnknown) {
    // The central hyperboloid with the rim in its near focus's plane: R = r, e from the rim's
    // angle (tan alpha = (e^2 - 1) / 2e) or from the camera at the far focus (d = r / (e - 1)).
    double e = std::sqrt(2.0);
    if (know.focal_px > 0) {
      const double t = rho / know.focal_px;
      e = t + std::hypot(t, 1.0);
      if (given_d > 0) {
        if (auto bad = distance_mismatch(r / (e - 1))) return fail(*bad);
      }
    } else if (given_d > 0) {
      e = 1 + r / given_d;
    } else {
      lines->push_back(Format(
          "assumed: K = -2 with the lens at the far focus (%.1f mm below the vertex): give "
          "--camera_distance or --focal_px to place it",
          r / (e - 1)));
    }
    return RimGeometry{-e * e, HyperboloidRimAngle(e)};
  }
  if (know.focal_px > 0) {
    g.alpha = std::atan(rho / know.focal_px);
    if (given_d > 0) {
      const auto implied = VertexDistance(r, g.K, g.alpha);
      if (!implied) return fail("focal_px: no such mirror sees its rim at this angle");
      if (auto bad = distance_mismatch(*implied)) return fail(*bad);
    }
    return g;
  }
  const double d = given_d > 0 ? given_d : 2 * D;  // a sphere without either fails Check()
  if (!(given_d > 0)) {
    lines->push_back(Format("assumed: the lens %.0f mm (two rim diameters) from the vertex: give "
                            "--camera_distance or --focal_px to place it", d));
  }
  const auto alpha = RimAngleForDistance(r, g.K, d);
  if (!alpha) {
    return fail(Format("camera_distance: no %s mirror of a %g mm rim reflects its rim to the "
                       "horizon for a lens %g mm away", MirrorKnowledgeName(know.mirror), D, d));
  }
  g.alpha = *alpha;
  return g;
}

// The start's mirror, its vertex's height above the lens and the lens's f (px) or m (px per mm).
struct StartShape {
  Conic<double> conic{1, -1};
  double vertex_z = 0, f = 0, alpha = 0;
  std::string basis;  // what it rests on, for the start's line
};

// From the rim's angle (ChooseRimGeometry): the rim reflects to the horizon.
std::optional<StartShape> ShapeFromRimAngle(const SingleMirrorKnowledge& know, double rho,
                                            std::vector<std::string>* lines, std::string* why) {
  const auto geometry = ChooseRimGeometry(know, rho, lines, why);
  if (!geometry) return std::nullopt;
  const double r = know.mirror_diameter / 2, alpha = geometry->alpha;
  const auto conic = RimConic(r, geometry->K, alpha);
  if (!conic) {
    *why = "focal_px: no such mirror reflects its rim to the horizon at this angle";
    return std::nullopt;
  }
  StartShape shape{conic->conic, 0, 0, alpha, "the rim reflects to the horizon (assumed)"};
  if (know.lens == LensKind::kTelecentric) {
    shape.vertex_z = know.camera_distance > 0 ? know.camera_distance : 2 * r;  // no effect
    shape.f = rho / r;
    return shape;
  }
  shape.vertex_z = r / std::tan(alpha) - conic->rim_sag;
  if (!(shape.vertex_z > 0)) {
    *why = Format("focal_px: the rim at %.1f deg from the lens axis puts the lens inside the "
                  "mirror", alpha * kDeg);
    return std::nullopt;
  }
  shape.f = rho / std::tan(alpha);
  return shape;
}

// From a central fit's unified model scaled by the rim (CentralMirrorFromUnified); the diameter
// checked against camera_distance (perspective) or magnification (telecentric).
std::optional<StartShape> ShapeFromUnified(const SingleMirrorKnowledge& know, double rho,
                                           std::vector<std::string>* lines, std::string* why) {
  const double D = know.mirror_diameter, r = D / 2;
  std::string reason;
  const auto central = CentralMirrorFromUnified(
      UnifiedParameters{know.unified_xi, know.unified_gamma}, know.lens, rho, D, &reason);
  if (!central) {
    *why = "unified: " + reason;
    return std::nullopt;
  }
  StartShape shape{central->mirror, 0, 0, 0,
                   Format("from the unified fit xi %g, gamma %g px", know.unified_xi,
                          know.unified_gamma)};
  if (know.lens == LensKind::kTelecentric) {
    SingleMirrorKnowledge magnification_only = know;  // the magnification check, as without it
    magnification_only.unified_xi = magnification_only.unified_gamma = 0;
    magnification_only.mirror = MirrorKnowledge::kParabolic;
    if (!ChooseRimGeometry(magnification_only, rho, lines, why)) return std::nullopt;
    shape.vertex_z = know.camera_distance > 0 ? know.camera_distance : 2 * r;  // no effect
    shape.f = central->magnification;
    return shape;
  }
  shape.vertex_z = central->CameraBelowVertexMm();
  shape.f = central->focal_px;
  shape.alpha = std::atan(rho / shape.f);
  if (know.camera_distance > 0) {
    const double off = Mismatch(shape.vertex_z, know.camera_distance);
    const std::string text = Format(
        "the %g mm rim seen at %.2f px with the unified fit puts the lens %.1f mm from the "
        "mirror's vertex, --camera_distance says %g mm (off by %.0f%%, tolerance %.0f%%)",
        D, rho, shape.vertex_z, know.camera_distance, 100 * off, 100 * know.distance_tolerance);
    if (off > know.distance_tolerance) {
      *why = "mirror_diameter: " + text + ": check the diameter (mm, across the rim), --unified "
             "and --camera_distance";
      return std::nullopt;
    }
    lines->push_back("diameter checked: " + text);
  }
  return shape;
}

// The knowledge with a diameter where none was measured (mirror_diameter 0), and its lines:
// from what else is known where that fixes the scale (a telecentric lens's magnification; a
// perspective lens's rough distance, through the start's own rule for the rest), else the nominal
// kNominalDiameterMm, said to leave the absolute size open. Unchanged where it was measured.
SingleMirrorKnowledge WithDiameter(const SingleMirrorKnowledge& know, double rho,
                                   std::vector<std::string>* lines, std::string* why) {
  if (know.mirror_diameter > 0) return know;
  SingleMirrorKnowledge out = know;
  if (know.lens == LensKind::kTelecentric && know.magnification > 0) {
    out.mirror_diameter = 2 * rho / know.magnification;
    lines->push_back(Format("mirror diameter not given: %.2f mm from the rim's %.2f px radius and "
                            "--magnification %g px per mm (the model's scale)",
                            out.mirror_diameter, rho, know.magnification));
    return out;
  }
  out.mirror_diameter = kNominalDiameterMm;
  if (know.lens == LensKind::kPerspective && know.camera_distance > 0) {
    // The start's geometry without the distance scales with the diameter: the distance it
    // implies at the nominal size gives the size at the given distance.
    SingleMirrorKnowledge trial = out;
    trial.camera_distance = 0;
    std::vector<std::string> ignored;
    const auto shape = know.unified_xi > 0 ? ShapeFromUnified(trial, rho, &ignored, why)
                                           : ShapeFromRimAngle(trial, rho, &ignored, why);
    if (!shape) return out;
    out.mirror_diameter = kNominalDiameterMm * know.camera_distance / shape->vertex_z;
    lines->push_back(Format(
        "mirror diameter not given: %.1f mm, where the start's rim geometry (below) puts the "
        "vertex --camera_distance %g mm from the lens; the model's scale is as rough as that "
        "distance (--mirror_diameter would fix it)",
        out.mirror_diameter, know.camera_distance));
    out.camera_distance = 0;  // used: it set the scale
    return out;
  }
  lines->push_back(Format(
      "mirror diameter not given: the model is drawn at a nominal %g mm rim, so its absolute "
      "size is not determined: directions and far points are not affected, but R, the lens's "
      "distance and its offset from the focus are in units of that nominal size "
      "(--mirror_diameter or --camera_distance would fix it)",
      kNominalDiameterMm));
  return out;
}

}  // namespace

std::optional<SingleMirrorStart> SingleMirrorStartFromRim(const MirrorRim& rim,
                                                          const SingleMirrorKnowledge& know_in,
                                                          int width, int height,
                                                          std::string* why) {
  auto fail = [&](const std::string& text) {
    if (why) *why = text;
    return std::nullopt;
  };
  if (const std::string bad = know_in.Check(); !bad.empty()) return fail(bad);
  if (!rim.found || !(rim.radius_px > 0)) return fail("images: no mirror rim given");
  SingleMirrorStart out;
  out.rim = rim;
  const double rho = rim.radius_px;
  const bool telecentric = know_in.lens == LensKind::kTelecentric;
  const bool unified = know_in.unified_xi > 0;
  out.lines.push_back(Format("mirror rim: centre (%.2f, %.2f) px, radius %.2f px, rms %.2f px over "
                             "%d edge points (coverage %.2f)",
                             rim.centre.x(), rim.centre.y(), rho, rim.rms_px, rim.edge_points,
                             rim.coverage));
  std::string reason;
  const SingleMirrorKnowledge know = WithDiameter(know_in, rho, &out.lines, &reason);
  const double r = know.mirror_diameter / 2;
  const auto shape = unified ? ShapeFromUnified(know, rho, &out.lines, &reason)
                             : ShapeFromRimAngle(know, rho, &out.lines, &reason);
  if (!shape) return fail(reason);
  const double f = shape->f, vertex_z = shape->vertex_z, alpha = shape->alpha;
  const Pinhole<double> cam{f, f, rim.centre.x(), rim.centre.y(), 0};
  out.rig = MakeSingleRig(shape->conic, know.lens, vertex_z, r, know.r_cam_fraction * r, cam,
                          width, height);
  out.rim_angle_rad = alpha;
  out.camera_distance_mm = vertex_z;
  if (know.mirror == MirrorKnowledge::kUnknown && !unified) {
    out.lines.push_back(std::string("unknown mirror: started as the central ") +
                        (telecentric ? "paraboloid" : "hyperboloid") +
                        " of this lens; its shape is estimated");
  }
  out.lines.push_back(
      "start: " + ConicLine(out.rig) +
      (telecentric
           ? Format(", telecentric lens %.4f px per mm, principal point at the rim centre "
                    "(the vertex placed %.1f mm above the lens: a telecentric image does not "
                    "depend on it)", f, vertex_z)
           : Format(", vertex %.1f mm above the lens, focal length %.1f px, principal point at "
                    "the rim centre (the rim %.1f deg from the lens axis)",
                    vertex_z, f, alpha * kDeg)) +
      "; " + shape->basis);
  const double given_d = know.camera_distance;
  if (know_in.mirror_diameter > 0 && !(telecentric ? know.magnification > 0
                                                   : given_d > 0 && (know.focal_px > 0 || unified))) {
    out.lines.push_back(
        telecentric ? "diameter not checked: the rim's px per mm is the magnification; "
                      "--magnification (px per mm) would check it"
                    : "diameter not checked: the rim's image fixes the focal length against the "
                      "diameter; --camera_distance with --focal_px or --unified would check it");
  }
  ChooseEstimate(know, &out);
  if (!(know_in.mirror_diameter > 0)) {
    out.comments.push_back(Format(
        "scale: no rim diameter was given; the model's is %.2f mm (%s).", know.mirror_diameter,
        know.mirror_diameter == kNominalDiameterMm
            ? "nominal: the absolute size is not determined; directions are not affected"
            : "from what was given; see init's output"));
  }
  return out;
}

std::optional<SingleMirrorStart> SingleMirrorStartFromPhotos(
    const std::vector<cv::Mat>& grey_images, const SingleMirrorKnowledge& knowledge,
    std::string* why, const MirrorRimOptions& rim_options) {
  if (const std::string bad = knowledge.Check(); !bad.empty()) {
    if (why) *why = bad;
    return std::nullopt;
  }
  if (grey_images.empty()) {
    if (why) *why = "images: no photos";
    return std::nullopt;
  }
  const MirrorRim rim = FindMirrorRim(grey_images, rim_options);
  if (!rim.found) {
    if (why) {
      *why = Format("images: no mirror rim found in the %zu photos: %s", grey_images.size(),
                    rim.why.c_str());
    }
    return std::nullopt;
  }
  return SingleMirrorStartFromRim(rim, knowledge, grey_images[0].cols, grey_images[0].rows, why);
}

std::vector<cv::Mat> GreyPhotosForRim(const std::vector<std::string>& images, size_t max_images) {
  std::vector<cv::Mat> greys;
  const size_t n = std::min(max_images, images.size());
  for (size_t i = 0; i < n; ++i) {
    greys.push_back(ToGrey(io::ReadImage(images[i * images.size() / n])));
  }
  return greys;
}

}  // namespace omni::detectors
