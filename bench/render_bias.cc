// Render bias of chessboard corners: are the X-junctions in POV-Ray renders where the model says?
// A controlled experiment (a timed run, not a test): a few chessboards through the rig (or seen
// directly by the pinhole), rendered by POV-Ray in small windows with several anti-aliasing
// settings, and by an independent oracle: the exact box-filtered pixel (S x S sub-pixel rays
// through RigModel::Unproject, intersected with the board, averaged). cv::cornerSubPix is started
// at the true corner (ComputeTruth) in every image with the detector's raw-refinement window
// (detectors/chessboard/chessboard_detector.cc: half = clamp(round(0.4 * side), 1, 6)); the mean radial and
// tangential offsets per ring then split the bias into
//   detector: cornerSubPix on the oracle image (exact pixels, no renderer involved);
//   renderer: POV-Ray image minus oracle (same refinement, same corners).
// Lens distortion is set to zero: the renders are compared before image_effects.
// The refinement is the detector's (detectors/common/corner_refine.h: RefineCornerInRaw); the lines
// marked "+cc" add its curvature-bias correction (RemoveCurvatureBias from each board's refined
// corners), as the chessboard detector does.
//
// Usage: render_bias MODEL OUT_DIR MODE CONFIG...
//   MODE: rig (4 boards at 700 and 1200 mm, both rings) or direct (draw_mirrors off, 2 tilted
//         boards in front of the pinhole: POV-Ray's camera and texture conventions alone).
//   CONFIG: oracle | noaa | aa3 | aa4 | aa5 | am1 | ss3 (3x focal and pixels, no AA, INTER_AREA
//           down by 3) | ss3aa (the same with the default AA) | raw:<povray AA flags>.
//   Environment: HALF (fixed cornerSubPix half-window instead of the detector's), SAMPLES (oracle
//   rays per pixel side, 8), RANGES ("700,1200") and PER (boards per range, 2) for rig mode.
//   Writes oracle.png, <config>.png and <config>_diff.png (128 + 4 (render - oracle), first window).
// Finding (docs in the session report): every POV-Ray setting agrees with the oracle to within
// 0.003 px radially; the oracle itself shows the +0.02 px outward bias, which the curvature model
// below reproduces per ring: it is cornerSubPix's straight-edge assumption, not the renderer.
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "detectors/common/corner_refine.h"
#include "io/model_file.h"
#include "model/rig_model.h"
#include "model/target.h"
#include "synthetic/pov_scene.h"
#include "synthetic/scene.h"

namespace omni {
namespace {

struct Window {
  int placement = 0, ring = 0;  // ring 0: direct view
  cv::Rect box;
};

struct Corner {
  int placement = 0, ring = 0, id = 0;
  Eigen::Vector2d truth;
  double side = 0;  // local square side in pixels
};

struct Setup {
  RigParams rig;
  synthetic::Scene scene;
  synthetic::SceneImage image;
  bool direct = false;
  std::vector<Corner> corners;
  std::vector<Window> windows;
};

Eigen::Vector2d PinholeProject(const RigParams& rig, const Eigen::Vector3d& p) {
  const double x = p.x() / p.z(), y = p.y() / p.z();
  return {rig.camera[kFx] * x + rig.camera[kSkew] * y + rig.camera[kCx], rig.camera[kFy] * y + rig.camera[kCy]};
}

Setup MakeSetup(const RigParams& rig_in, bool direct) {
  Setup s;
  s.rig = rig_in;
  s.rig.distortion = {0, 0, 0, 0, 0};
  s.direct = direct;
  s.image.name = "0001";
  if (direct) {
    // Two boards ~600 mm in front of the camera, tilted so no edge is parallel to a pixel axis.
    for (int k = 0; k < 2; ++k) {
      TargetSpec spec;
      spec.rows = 5;
      spec.cols = 6;
      spec.square_mm = k == 0 ? 12.0 : 6.0;
      s.scene.targets.push_back(spec);
      synthetic::Placement p;
      p.target = k;
      p.cam_from_target_rotation =
          (Eigen::AngleAxisd(0.3 + 0.4 * k, Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(0.35, Eigen::Vector3d(1, 1, 0).normalized()))
              .toRotationMatrix();
      p.cam_from_target_translation = Eigen::Vector3d(k == 0 ? -90 : 40, k == 0 ? -40 : 60, 600);
      s.image.placements.push_back(p);
    }
  } else {
    synthetic::RingPlacement rings;
    // RANGES="700,1200" and PER=2 by default (environment): more boards, smaller standard errors.
    rings.ranges_mm = {700, 1200};
    if (const char* e = std::getenv("RANGES")) {
      rings.ranges_mm.clear();
      for (std::string t(e); !t.empty();) {
        const auto k = t.find(',');
        rings.ranges_mm.push_back(std::atof(t.substr(0, k).c_str()));
        t = k == std::string::npos ? "" : t.substr(k + 1);
      }
    }
    rings.per_range = std::getenv("PER") ? std::atoi(std::getenv("PER")) : 2;
    rings.rows = 4;
    rings.cols = 5;
    rings.square_at_1m_mm = 60.0;
    synthetic::AddRingImage(RigModel(s.rig), rings, &s.scene);
    s.image = s.scene.images.back();
  }
  s.scene.images = {s.image};

  // Truth and windows.
  const RigModel model(s.rig);
  std::map<std::tuple<int, int, int>, Eigen::Vector2d> px;
  if (direct) {
    for (size_t p = 0; p < s.image.placements.size(); ++p) {
      const auto& pl = s.image.placements[p];
      const TargetSpec& spec = s.scene.targets[pl.target];
      for (int id : CornerIds(spec)) {
        const Eigen::Vector3d q =
            pl.cam_from_target_rotation * CornerInTarget(spec, id) + pl.cam_from_target_translation;
        px[{static_cast<int>(p), 0, id}] = PinholeProject(s.rig, q);
      }
    }
  } else {
    for (const auto& t : synthetic::ComputeTruth(model, s.scene, s.image)) {
      for (int m = 0; m < 2; ++m)
        if (t.pixel[m]) px[{t.placement, m + 1, t.id}] = *t.pixel[m];
    }
  }
  std::map<std::pair<int, int>, cv::Rect> boxes;
  for (const auto& [key, p] : px) {
    const auto [placement, ring, id] = key;
    const int cols = s.scene.targets[s.image.placements[placement].target].cols;
    double side = 1e9;
    for (int nb : {id - 1, id + 1, id - cols, id + cols}) {
      if ((nb == id - 1 && id % cols == 0) || (nb == id + 1 && nb % cols == 0)) continue;
      const auto it = px.find({placement, ring, nb});
      if (it != px.end()) side = std::min(side, (it->second - p).norm());
    }
    if (side > 1e8) continue;
    s.corners.push_back({placement, ring, id, p, side});
    const int m = 6 + static_cast<int>(std::ceil(side));
    const cv::Rect r(static_cast<int>(p.x()) - m, static_cast<int>(p.y()) - m, 2 * m + 1, 2 * m + 1);
    auto& b = boxes[{placement, ring}];
    b = b.area() == 0 ? r : (b | r);
  }
  const cv::Rect frame(0, 0, s.rig.image_width, s.rig.image_height);
  for (const auto& [key, b] : boxes) s.windows.push_back({key.first, key.second, b & frame});
  return s;
}

// ---- the oracle: exact box filter by sub-pixel ray casting ----
struct BoardGeom {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  TargetSpec spec;
  Eigen::Vector4d sheet;
};

// Radiance (0..1) along a ray in C: nearest board hit, checker (parity chosen by `parity`),
// white sheet margin, black background.
double Radiance(const std::vector<BoardGeom>& boards, const Eigen::Vector3d& o,
                const Eigen::Vector3d& d, int parity) {
  double best = 1e18, value = 0.0;
  for (const BoardGeom& b : boards) {
    const Eigen::Vector3d n = b.R.col(2);
    const double den = n.dot(d);
    if (std::abs(den) < 1e-12) continue;
    const double s = n.dot(b.t - o) / den;
    if (s <= 0 || s >= best) continue;
    const Eigen::Vector3d q = b.R.transpose() * (o + s * d - b.t);
    if (q.x() < b.sheet[0] || q.y() < b.sheet[1] || q.x() > b.sheet[2] || q.y() > b.sheet[3]) continue;
    best = s;
    const double sq = b.spec.square_mm;
    if (q.x() >= -sq && q.y() >= -sq && q.x() <= b.spec.cols * sq && q.y() <= b.spec.rows * sq) {
      const long k = static_cast<long>(std::floor(q.x() / sq)) + static_cast<long>(std::floor(q.y() / sq));
      value = ((k & 1) == parity) ? 1.0 : 0.0;
    } else {
      value = 1.0;
    }
  }
  return value;
}

cv::Mat RenderOracle(const Setup& s, int samples, int parity) {
  std::vector<BoardGeom> boards;
  for (const auto& p : s.image.placements) {
    const TargetSpec& spec = s.scene.targets[p.target];
    boards.push_back({p.cam_from_target_rotation, p.cam_from_target_translation, spec, SheetBounds(spec)});
  }
  const RigModel model(s.rig);
  cv::Mat img(s.rig.image_height, s.rig.image_width, CV_8UC1, cv::Scalar(0));
  const double fx = s.rig.camera[kFx], fy = s.rig.camera[kFy], cx = s.rig.camera[kCx], cy = s.rig.camera[kCy],
               skew = s.rig.camera[kSkew];
  for (const Window& w : s.windows) {
    for (int v = w.box.y; v < w.box.y + w.box.height; ++v) {
      for (int u = w.box.x; u < w.box.x + w.box.width; ++u) {
        double sum = 0;
        int n = 0;
        for (int a = 0; a < samples; ++a) {
          for (int b = 0; b < samples; ++b) {
            // Pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5] (docs/design.md, Conventions).
            const Eigen::Vector2d q(u - 0.5 + (a + 0.5) / samples, v - 0.5 + (b + 0.5) / samples);
            if (s.direct) {
              const double yn = (q.y() - cy) / fy, xn = (q.x() - cx - skew * yn) / fx;
              sum += Radiance(boards, Eigen::Vector3d::Zero(), Eigen::Vector3d(xn, yn, 1).normalized(), parity);
              ++n;
            } else if (const auto ray = model.Unproject(q)) {
              sum += Radiance(boards, ray->ray.origin, ray->ray.direction, parity);
              ++n;
            }
          }
        }
        img.at<uchar>(v, u) = cv::saturate_cast<uchar>(n ? 255.0 * sum / n : 0.0);
      }
    }
  }
  return img;
}

// ---- POV-Ray ----
bool RunPov(const std::string& pov_text, const std::string& png, int W, int H, const cv::Rect& box,
            const std::string& aa_flags) {
  std::string pov = png.substr(0, png.size() - 4) + ".pov";
  std::ofstream(pov) << pov_text;
  const auto slash = png.rfind('/');
  char cmd[2048];
  std::snprintf(cmd, sizeof(cmd),
                "cd '%s' && povray -D +I'%s' +O'%s' +FN8 File_Gamma=1.0 +W%d +H%d %s +SC%d +EC%d "
                "+SR%d +ER%d +WT1 > '%s.log' 2>&1",
                png.substr(0, slash).c_str(), pov.substr(slash + 1).c_str(), png.substr(slash + 1).c_str(),
                W, H, aa_flags.c_str(), box.x + 1, box.x + box.width, box.y + 1, box.y + box.height,
                png.substr(slash + 1).c_str());
  return std::system(cmd) == 0;
}

cv::Mat RenderPov(const Setup& s, const std::string& config, const std::string& dir, double* seconds) {
  int scale = 1;
  std::string flags;
  if (config == "noaa") flags = "-A";
  else if (config == "aa3") flags = "+A0.0 +AM2 +R3";
  else if (config == "aa4") flags = "+A0.0 +AM2 +R4";
  else if (config == "aa5") flags = "+A0.0 +AM2 +R5";
  else if (config == "am1") flags = "+A0.0 +AM1 +R5 -J";
  else if (config == "ss3") { flags = "-A"; scale = 3; }
  else if (config == "ss3aa") { flags = "+A0.0 +AM2 +R3"; scale = 3; }
  else if (config.rfind("raw:", 0) == 0) flags = config.substr(4);
  else { std::fprintf(stderr, "unknown config %s\n", config.c_str()); std::exit(2); }
  const RigParams rig = scale == 1 ? s.rig
      : synthetic::RigAtImageSize(s.rig, s.rig.image_width * scale, s.rig.image_height * scale);
  synthetic::SceneContent content = synthetic::ContentOf(s.scene, s.image);
  content.draw_mirrors = !s.direct;
  const std::string pov = synthetic::PovSceneText(rig, content);
  cv::Mat out(s.rig.image_height, s.rig.image_width, CV_8UC1, cv::Scalar(0));
  const auto t0 = std::chrono::steady_clock::now();
  int k = 0;
  for (const Window& w : s.windows) {
    const cv::Rect big(w.box.x * scale, w.box.y * scale, w.box.width * scale, w.box.height * scale);
    const std::string png = dir + "/" + config.substr(0, 8) + "_w" + std::to_string(k++) + ".png";
    if (!RunPov(pov, png, rig.image_width, rig.image_height, big, flags)) {
      std::fprintf(stderr, "povray failed for %s\n", png.c_str());
      std::exit(1);
    }
    cv::Mat grey, small;
    cv::cvtColor(cv::imread(png, cv::IMREAD_COLOR)(big), grey, cv::COLOR_BGR2GRAY);
    if (scale > 1) cv::resize(grey, small, w.box.size(), 0, 0, cv::INTER_AREA);  // box filter
    else small = grey;
    small.copyTo(out(w.box));
  }
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

// ---- measurement ----
struct RingStats {
  int n = 0;
  double radial = 0, tangential = 0, rms = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();  // mean (du, dv): a constant image shift
};

// The detector's raw refinement (detectors/common/corner_refine.h) started at the true corners; with
// `correct` also its curvature-bias correction from each board's refined neighbours.
std::map<int, RingStats> Measure(const Setup& s, const cv::Mat& img, int half_override, bool correct,
                                 std::vector<Eigen::Vector2d>* errors) {
  std::map<int, RingStats> stats;
  const double cx = s.rig.camera[kCx], cy = s.rig.camera[kCy];
  errors->assign(s.corners.size(), Eigen::Vector2d(NAN, NAN));
  // Refined corners per board (placement, ring), row-major by id as the detector holds them.
  std::map<std::pair<int, int>, std::vector<std::optional<Eigen::Vector2d>>> grids;
  std::map<std::pair<int, int>, std::vector<int>> halves;
  for (const Corner& c : s.corners) {
    const TargetSpec& spec = s.scene.targets[s.image.placements[c.placement].target];
    grids[{c.placement, c.ring}].resize(spec.rows * spec.cols);
    halves[{c.placement, c.ring}].resize(spec.rows * spec.cols, 1);
  }
  for (const Corner& c : s.corners) {
    const int half = half_override > 0 ? half_override
                                       : std::clamp(static_cast<int>(std::lround(0.4 * c.side)), 1, 6);
    Eigen::Vector2d p = c.truth;
    if (p.x() < half + 3 || p.y() < half + 3 || p.x() > img.cols - half - 4 || p.y() > img.rows - half - 4)
      continue;
    if (!detectors::RefineCornerInRaw(img, half, &p)) continue;
    grids[{c.placement, c.ring}][c.id] = p;
    halves[{c.placement, c.ring}][c.id] = half;
  }
  if (correct) {
    for (auto& [key, grid] : grids) {
      const TargetSpec& spec = s.scene.targets[s.image.placements[key.first].target];
      detectors::RemoveCurvatureBias(spec.rows, spec.cols, halves[key], &grid);
    }
  }
  for (size_t i = 0; i < s.corners.size(); ++i) {
    const Corner& c = s.corners[i];
    const auto& p = grids[{c.placement, c.ring}][c.id];
    if (!p) continue;
    const Eigen::Vector2d e = *p - c.truth;
    if (e.norm() > 0.5) continue;  // as the detector evaluation: a lost corner, not a bias
    (*errors)[i] = e;
    // Radial: away from the principal point (rings); direct view: the same definition.
    const Eigen::Vector2d r = Eigen::Vector2d(c.truth.x() - cx, c.truth.y() - cy).normalized();
    RingStats& st = stats[c.ring];
    ++st.n;
    st.radial += e.dot(r);
    st.tangential += r.x() * e.y() - r.y() * e.x();
    st.rms += e.squaredNorm();
    st.mean += e;
  }
  for (auto& [ring, st] : stats) {
    st.mean /= st.n;
    st.radial /= st.n;
    st.tangential /= st.n;
    st.rms = std::sqrt(st.rms / st.n);
  }
  return stats;
}

void Report(const std::string& name, const std::map<int, RingStats>& st, double seconds) {
  std::printf("%-10s", name.c_str());
  for (const auto& [ring, s] : st)
    std::printf("  ring %d: n %3d radial %+.4f tang %+.4f (du %+.4f dv %+.4f) rms %.4f", ring, s.n,
                s.radial, s.tangential, s.mean.x(), s.mean.y(), s.rms);
  if (seconds >= 0) std::printf("  (%.1f s)", seconds);
  std::printf("\n");
}

// Radial/tangential mean of per-corner differences a - b (both measured).
void ReportDiff(const std::string& name, const Setup& s, const std::vector<Eigen::Vector2d>& a,
                const std::vector<Eigen::Vector2d>& b) {
  std::map<int, RingStats> st;
  for (size_t i = 0; i < s.corners.size(); ++i) {
    if (std::isnan(a[i].x()) || std::isnan(b[i].x())) continue;
    const Corner& c = s.corners[i];
    const Eigen::Vector2d e = a[i] - b[i];
    const Eigen::Vector2d r =
        Eigen::Vector2d(c.truth.x() - s.rig.camera[kCx], c.truth.y() - s.rig.camera[kCy]).normalized();
    RingStats& x = st[c.ring];
    ++x.n;
    x.radial += e.dot(r);
    x.tangential += r.x() * e.y() - r.y() * e.x();
    x.rms += e.squaredNorm();
    x.mean += e;
  }
  for (auto& [ring, x] : st) {
    x.mean /= x.n;
    x.radial /= x.n;
    x.tangential /= x.n;
    x.rms = std::sqrt(x.rms / x.n);
  }
  Report(name, st, -1);
}

// The mechanism: cv::cornerSubPix puts the corner where the tangent lines of the edge pixels in
// its window meet. The image of a straight board line through the mirrors is curved (curvature
// vector k towards its centre of curvature); the tangent at arc length s from the corner passes
// k s^2 / 2 beside it on the convex side, so the estimate moves by about -a h^2 k per edge line
// (h: the window's half size, a: the window's weighted mean of s^2 / (2 h^2)). Model per corner:
// m = -h^2 (k_row + k_col), from RigModel::Project of board points +-0.3 squares along the row
// and the column; fitted e = a m over all corners of the image.
void CurvatureModel(const Setup& s, const std::vector<Eigen::Vector2d>& errors, int half_override) {
  if (s.direct) return;
  const RigModel model(s.rig);
  double em = 0, mm = 0;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> pairs;  // (e, m)
  std::vector<Eigen::Vector2d> radials;
  std::vector<int> rings;
  for (size_t i = 0; i < s.corners.size(); ++i) {
    if (std::isnan(errors[i].x())) continue;
    const Corner& c = s.corners[i];
    const auto& pl = s.image.placements[c.placement];
    const TargetSpec& spec = s.scene.targets[pl.target];
    const Mirror mirror = c.ring == 1 ? Mirror::kOne : Mirror::kTwo;
    const double delta = 0.3 * spec.square_mm;
    Eigen::Vector2d k_sum = Eigen::Vector2d::Zero();
    bool ok = true;
    for (const Eigen::Vector3d& dir : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0)}) {
      Eigen::Vector2d q[3];
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d in_target = CornerInTarget(spec, c.id) + (j - 1) * delta * dir;
        const auto px = model.Project(pl.cam_from_target_rotation * in_target + pl.cam_from_target_translation, mirror);
        if (!px) { ok = false; break; }
        q[j] = *px;
      }
      if (!ok) break;
      const Eigen::Vector2d d1 = (q[2] - q[0]) / 2, d2 = q[2] - 2 * q[1] + q[0];
      const Eigen::Vector2d t = d1.normalized();
      k_sum += (d2 - d2.dot(t) * t) / d1.squaredNorm();  // curvature vector (1/px)
    }
    if (!ok) continue;
    const int half = half_override > 0 ? half_override
                                       : std::clamp(static_cast<int>(std::lround(0.4 * c.side)), 1, 6);
    const Eigen::Vector2d m = -half * half * k_sum;
    pairs.emplace_back(errors[i], m);
    radials.push_back(Eigen::Vector2d(c.truth.x() - s.rig.camera[kCx], c.truth.y() - s.rig.camera[kCy]).normalized());
    rings.push_back(c.ring);
    em += errors[i].dot(m);
    mm += m.squaredNorm();
  }
  const double a = em / mm;
  for (int ring : {1, 2}) {
    double er = 0, mr = 0, ee = 0, mmr = 0, em_r = 0;
    int n = 0;
    for (size_t k = 0; k < pairs.size(); ++k) {
      if (rings[k] != ring) continue;
      const double x = pairs[k].first.dot(radials[k]), y = a * pairs[k].second.dot(radials[k]);
      er += x; mr += y; ee += x * x; mmr += y * y; em_r += x * y;
      ++n;
    }
    if (n == 0) continue;
    const double cov = em_r / n - er / n * mr / n, vx = ee / n - er * er / n / n, vy = mmr / n - mr * mr / n / n;
    std::printf("  curvature model (a = %.3f): ring %d measured radial %+.4f, predicted %+.4f, "
                "per-corner correlation %.2f\n", a, ring, er / n, mr / n, cov / std::sqrt(vx * vy));
  }
}

}  // namespace
}  // namespace omni

int main(int argc, char** argv) {
  using namespace omni;
  if (argc < 4) {
    std::fprintf(stderr, "usage: render_bias MODEL OUT_DIR rig|direct CONFIG...\n");
    return 2;
  }
  const std::string dir = argv[2];
  std::filesystem::create_directories(dir);
  const Setup s = MakeSetup(io::ReadModelFile(argv[1]), std::string(argv[3]) == "direct");
  std::printf("%zu corners in %zu windows:", s.corners.size(), s.windows.size());
  for (const auto& w : s.windows) std::printf(" [p%d r%d %dx%d]", w.placement, w.ring, w.box.width, w.box.height);
  std::printf("\n");
  const int half_override = std::getenv("HALF") ? std::atoi(std::getenv("HALF")) : 0;
  const int samples = std::getenv("SAMPLES") ? std::atoi(std::getenv("SAMPLES")) : 8;

  auto t0 = std::chrono::steady_clock::now();
  cv::Mat oracle = RenderOracle(s, samples, 0);
  const double oracle_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  cv::imwrite(dir + "/oracle.png", oracle);
  if (const char* b = std::getenv("ORACLE_BLUR")) {  // Gaussian sigma (px): a blurrier camera
    const cv::Mat sharp = oracle.clone();
    cv::GaussianBlur(sharp, oracle, cv::Size(0, 0), std::atof(b));
  }
  std::vector<Eigen::Vector2d> e_oracle;
  Report("oracle", Measure(s, oracle, half_override, false, &e_oracle), oracle_s);
  CurvatureModel(s, e_oracle, half_override);
  std::vector<Eigen::Vector2d> e_oracle_curv;
  Report("oracle+cc", Measure(s, oracle, half_override, true, &e_oracle_curv), -1);
  for (int i = 4; i < argc; ++i) {
    const std::string config = argv[i];
    double seconds = 0;
    const cv::Mat img = RenderPov(s, config, dir, &seconds);
    cv::imwrite(dir + "/" + config.substr(0, 8) + ".png", img);
    std::vector<Eigen::Vector2d> e;
    Report(config, Measure(s, img, half_override, false, &e), seconds);
    ReportDiff("  -oracle", s, e, e_oracle);
    std::vector<Eigen::Vector2d> e_curv;
    Report(config + "+cc", Measure(s, img, half_override, true, &e_curv), -1);
    // Pixel agreement with the oracle (either checker parity): mean |difference| in the windows.
    const cv::Mat inv = 255 - oracle;
    double d0 = 0, d1 = 0, n = 0, sd0 = 0, sd1 = 0;
    for (const auto& w : s.windows) {
      d0 += cv::norm(img(w.box), oracle(w.box), cv::NORM_L1);
      d1 += cv::norm(img(w.box), inv(w.box), cv::NORM_L1);
      cv::Mat a, b, c;
      img(w.box).convertTo(a, CV_64F);
      oracle(w.box).convertTo(b, CV_64F);
      inv(w.box).convertTo(c, CV_64F);
      sd0 += cv::sum(a - b)[0];
      sd1 += cv::sum(a - c)[0];
      n += w.box.area();
    }
    const bool same = d0 < d1;
    // Where the difference sits: pixels the oracle calls pure black, pure white, or edge.
    double sum[3] = {0, 0, 0}, cnt[3] = {0, 0, 0};
    const cv::Mat& ref = same ? oracle : inv;
    for (const auto& w : s.windows) {
      for (int v = w.box.y; v < w.box.y + w.box.height; ++v) {
        for (int u = w.box.x; u < w.box.x + w.box.width; ++u) {
          const int o = ref.at<uchar>(v, u), k = o == 0 ? 0 : (o == 255 ? 1 : 2);
          sum[k] += img.at<uchar>(v, u) - o;
          ++cnt[k];
        }
      }
    }
    {
      cv::Mat a, b, diff;
      img.convertTo(a, CV_32F);
      ref.convertTo(b, CV_32F);
      diff = 128 + 4 * (a - b);  // 4x the difference around mid grey
      diff.convertTo(diff, CV_8U);
      cv::imwrite(dir + "/" + config.substr(0, 8) + "_diff.png", diff(s.windows[0].box));
    }
    std::printf("  mean diff on oracle-black %+.3f (%.0f px), white %+.3f (%.0f px), edge %+.3f (%.0f px)\n",
                sum[0] / std::max(1.0, cnt[0]), cnt[0], sum[1] / std::max(1.0, cnt[1]), cnt[1],
                sum[2] / std::max(1.0, cnt[2]), cnt[2]);
    std::printf("  pixels vs oracle (%s parity): mean |diff| %.2f grey levels, mean diff %+.3f\n",
                same ? "same" : "inverted", (same ? d0 : d1) / n, (same ? sd0 : sd1) / n);
  }
  return 0;
}
