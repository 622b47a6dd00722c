#include "synthetic/render_bias.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/text_append.h"
#include "model/rig_model.h"
#include "model/target.h"
#include "synthetic/pov_scene.h"

namespace omni::synthetic {
namespace {

Eigen::Vector2d PinholeProject(const RigParams& rig, const Eigen::Vector3d& p) {
  const double x = p.x() / p.z(), y = p.y() / p.z();
  return {rig.camera[kFx] * x + rig.camera[kSkew] * y + rig.camera[kCx],
          rig.camera[kFy] * y + rig.camera[kCy]};
}

// The boards' placements and printed faces, for the oracle's rays.
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
    if (q.x() < b.sheet[0] || q.y() < b.sheet[1] || q.x() > b.sheet[2] || q.y() > b.sheet[3]) {
      continue;
    }
    best = s;
    const double sq = b.spec.square_mm;
    if (q.x() >= -sq && q.y() >= -sq && q.x() <= b.spec.cols * sq && q.y() <= b.spec.rows * sq) {
      const long k = static_cast<long>(std::floor(q.x() / sq)) +
                     static_cast<long>(std::floor(q.y() / sq));
      value = ((k & 1) == parity) ? 1.0 : 0.0;
    } else {
      value = 1.0;
    }
  }
  return value;
}

// The POV-Ray flags and supersampling scale of a config; false for an unknown one.
bool PovConfig(const std::string& config, std::string* flags, int* scale) {
  *scale = 1;
  if (config == "noaa") *flags = "-A";
  else if (config == "aa3") *flags = "+A0.0 +AM2 +R3";
  else if (config == "aa4") *flags = "+A0.0 +AM2 +R4";
  else if (config == "aa5") *flags = "+A0.0 +AM2 +R5";
  else if (config == "am1") *flags = "+A0.0 +AM1 +R5 -J";
  else if (config == "ss3") { *flags = "-A"; *scale = 3; }
  else if (config == "ss3aa") { *flags = "+A0.0 +AM2 +R3"; *scale = 3; }
  else if (config.rfind("raw:", 0) == 0) *flags = config.substr(4);
  else return false;
  return true;
}

bool RunPov(const std::string& pov_text, const std::string& png, int W, int H, const cv::Rect& box,
            const std::string& aa_flags) {
  std::string pov = png.substr(0, png.size() - 4) + ".pov";
  std::ofstream(pov) << pov_text;
  const auto slash = png.rfind('/');
  char cmd[2048];
  std::snprintf(cmd, sizeof(cmd),
                "cd '%s' && povray -D +I'%s' +O'%s' +FN8 File_Gamma=1.0 +W%d +H%d %s +SC%d +EC%d "
                "+SR%d +ER%d +WT1 > '%s.log' 2>&1",
                png.substr(0, slash).c_str(), pov.substr(slash + 1).c_str(),
                png.substr(slash + 1).c_str(), W, H, aa_flags.c_str(), box.x + 1,
                box.x + box.width, box.y + 1, box.y + box.height, png.substr(slash + 1).c_str());
  return std::system(cmd) == 0;
}

void Accumulate(const BiasSetup& s, size_t i, const Eigen::Vector2d& e,
                std::map<int, RingBias>* stats) {
  const BiasCorner& c = s.corners[i];
  // Radial: away from the principal point (rings); direct view: the same definition.
  const Eigen::Vector2d r =
      Eigen::Vector2d(c.truth.x() - s.rig.camera[kCx], c.truth.y() - s.rig.camera[kCy]).normalized();
  RingBias& st = (*stats)[c.ring];
  ++st.n;
  st.radial += e.dot(r);
  st.tangential += r.x() * e.y() - r.y() * e.x();
  st.rms += e.squaredNorm();
  st.mean += e;
}

}  // namespace

BiasSetup MakeBiasSetup(const RigParams& rig, bool direct, const std::vector<double>& ranges_mm,
                        int per_range) {
  BiasSetup s;
  s.rig = rig;
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
      Placement p;
      p.target = k;
      p.cam_from_target_rotation =
          (Eigen::AngleAxisd(0.3 + 0.4 * k, Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(0.35, Eigen::Vector3d(1, 1, 0).normalized()))
              .toRotationMatrix();
      p.cam_from_target_translation = Eigen::Vector3d(k == 0 ? -90 : 40, k == 0 ? -40 : 60, 600);
      s.image.placements.push_back(p);
    }
  } else {
    RingPlacement rings;
    rings.ranges_mm = ranges_mm;
    rings.per_range = per_range;
    rings.rows = 4;
    rings.cols = 5;
    rings.square_at_1m_mm = 60.0;
    AddRingImage(RigModel(s.rig), rings, &s.scene);
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
    for (const auto& t : ComputeTruth(model, s.scene, s.image)) {
      for (int m = 0; m < 2; ++m) {
        if (t.pixel[m]) px[{t.placement, m + 1, t.id}] = *t.pixel[m];
      }
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
    s.corners.push_back({placement, ring, id, 0, p, side});
    const int m = 6 + static_cast<int>(std::ceil(side));
    const cv::Rect r(static_cast<int>(p.x()) - m, static_cast<int>(p.y()) - m, 2 * m + 1, 2 * m + 1);
    auto& b = boxes[{placement, ring}];
    b = b.area() == 0 ? r : (b | r);
  }
  const cv::Rect frame(0, 0, s.rig.image_width, s.rig.image_height);
  std::map<std::pair<int, int>, int> board_of;
  for (const auto& [key, b] : boxes) {
    board_of[key] = static_cast<int>(s.boards.size());
    const TargetSpec& spec = s.scene.targets[s.image.placements[key.first].target];
    s.boards.emplace_back(spec.rows, spec.cols);
    s.windows.push_back({key.first, key.second, b & frame});
  }
  for (BiasCorner& c : s.corners) c.board = board_of[{c.placement, c.ring}];
  return s;
}

int DetectorHalfWindow(double side, int half_override) {
  return half_override > 0 ? half_override
                           : std::clamp(static_cast<int>(std::lround(0.4 * side)), 1, 6);
}

cv::Mat RenderOracle(const BiasSetup& s, int samples, int parity) {
  std::vector<BoardGeom> boards;
  for (const auto& p : s.image.placements) {
    const TargetSpec& spec = s.scene.targets[p.target];
    boards.push_back({p.cam_from_target_rotation, p.cam_from_target_translation, spec,
                      SheetBounds(spec)});
  }
  const RigModel model(s.rig);
  cv::Mat img(s.rig.image_height, s.rig.image_width, CV_8UC1, cv::Scalar(0));
  const double fx = s.rig.camera[kFx], fy = s.rig.camera[kFy], cx = s.rig.camera[kCx],
               cy = s.rig.camera[kCy], skew = s.rig.camera[kSkew];
  for (const BiasWindow& w : s.windows) {
    for (int v = w.box.y; v < w.box.y + w.box.height; ++v) {
      for (int u = w.box.x; u < w.box.x + w.box.width; ++u) {
        double sum = 0;
        int n = 0;
        for (int a = 0; a < samples; ++a) {
          for (int b = 0; b < samples; ++b) {
            // Pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5] (docs/design.md,
            // Conventions).
            const Eigen::Vector2d q(u - 0.5 + (a + 0.5) / samples, v - 0.5 + (b + 0.5) / samples);
            if (s.direct) {
              const double yn = (q.y() - cy) / fy, xn = (q.x() - cx - skew * yn) / fx;
              sum += Radiance(boards, Eigen::Vector3d::Zero(),
                              Eigen::Vector3d(xn, yn, 1).normalized(), parity);
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

cv::Mat RenderPovWindows(const BiasSetup& s, const std::string& config, const std::string& dir,
                         double* seconds) {
  int scale = 1;
  std::string flags;
  if (!PovConfig(config, &flags, &scale)) throw std::invalid_argument("unknown config " + config);
  const RigParams rig = scale == 1 ? s.rig
      : RigAtImageSize(s.rig, s.rig.image_width * scale, s.rig.image_height * scale);
  SceneContent content = ContentOf(s.scene, s.image);
  content.draw_mirrors = !s.direct;
  const std::string pov = PovSceneText(rig, content);
  cv::Mat out(s.rig.image_height, s.rig.image_width, CV_8UC1, cv::Scalar(0));
  const auto t0 = std::chrono::steady_clock::now();
  int k = 0;
  for (const BiasWindow& w : s.windows) {
    const cv::Rect big(w.box.x * scale, w.box.y * scale, w.box.width * scale,
                       w.box.height * scale);
    const std::string png = dir + "/" + config.substr(0, 8) + "_w" + std::to_string(k++) + ".png";
    if (!RunPov(pov, png, rig.image_width, rig.image_height, big, flags)) {
      throw std::runtime_error("povray failed for " + png);
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

std::map<int, RingBias> BiasByRing(const BiasSetup& s, const std::vector<Eigen::Vector2d>& errors) {
  std::map<int, RingBias> stats;
  for (size_t i = 0; i < s.corners.size(); ++i) {
    if (!std::isnan(errors[i].x())) Accumulate(s, i, errors[i], &stats);
  }
  for (auto& [ring, st] : stats) {
    st.mean /= st.n;
    st.radial /= st.n;
    st.tangential /= st.n;
    st.rms = std::sqrt(st.rms / st.n);
  }
  return stats;
}

std::vector<Eigen::Vector2d> ErrorsOf(const BiasSetup& s,
                                      const std::vector<std::optional<Eigen::Vector2d>>& refined) {
  std::vector<Eigen::Vector2d> errors(s.corners.size(), Eigen::Vector2d(NAN, NAN));
  for (size_t i = 0; i < s.corners.size(); ++i) {
    if (!refined[i]) continue;
    const Eigen::Vector2d e = *refined[i] - s.corners[i].truth;
    if (e.norm() > 0.5) continue;
    errors[i] = e;
  }
  return errors;
}

std::vector<Eigen::Vector2d> Difference(const std::vector<Eigen::Vector2d>& a,
                                        const std::vector<Eigen::Vector2d>& b) {
  std::vector<Eigen::Vector2d> d(a.size(), Eigen::Vector2d(NAN, NAN));
  for (size_t i = 0; i < a.size(); ++i) {
    if (!std::isnan(a[i].x()) && !std::isnan(b[i].x())) d[i] = a[i] - b[i];
  }
  return d;
}

std::string BiasLine(const std::string& name, const std::map<int, RingBias>& stats,
                     double seconds) {
  std::string out;
  io::AppendFormat(&out, "%-10s", name.c_str());
  for (const auto& [ring, s] : stats) {
    io::AppendFormat(&out, "  ring %d: n %3d radial %+.4f tang %+.4f (du %+.4f dv %+.4f) rms %.4f",
                     ring, s.n, s.radial, s.tangential, s.mean.x(), s.mean.y(), s.rms);
  }
  if (seconds >= 0) io::AppendFormat(&out, "  (%.1f s)", seconds);
  return out + "\n";
}

std::string WindowsLine(const BiasSetup& s) {
  std::string out;
  io::AppendFormat(&out, "%zu corners in %zu windows:", s.corners.size(), s.windows.size());
  for (const auto& w : s.windows) {
    io::AppendFormat(&out, " [p%d r%d %dx%d]", w.placement, w.ring, w.box.width, w.box.height);
  }
  return out + "\n";
}

std::string CurvatureModelText(const BiasSetup& s, const std::vector<Eigen::Vector2d>& errors,
                               int half_override) {
  if (s.direct) return "";
  const RigModel model(s.rig);
  double em = 0, mm = 0;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> pairs;  // (e, m)
  std::vector<Eigen::Vector2d> radials;
  std::vector<int> rings;
  for (size_t i = 0; i < s.corners.size(); ++i) {
    if (std::isnan(errors[i].x())) continue;
    const BiasCorner& c = s.corners[i];
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
        const auto px = model.Project(
            pl.cam_from_target_rotation * in_target + pl.cam_from_target_translation, mirror);
        if (!px) {
          ok = false;
          break;
        }
        q[j] = *px;
      }
      if (!ok) break;
      const Eigen::Vector2d d1 = (q[2] - q[0]) / 2, d2 = q[2] - 2 * q[1] + q[0];
      const Eigen::Vector2d t = d1.normalized();
      k_sum += (d2 - d2.dot(t) * t) / d1.squaredNorm();  // curvature vector (1/px)
    }
    if (!ok) continue;
    const int half = DetectorHalfWindow(c.side, half_override);
    const Eigen::Vector2d m = -half * half * k_sum;
    pairs.emplace_back(errors[i], m);
    radials.push_back(
        Eigen::Vector2d(c.truth.x() - s.rig.camera[kCx], c.truth.y() - s.rig.camera[kCy])
            .normalized());
    rings.push_back(c.ring);
    em += errors[i].dot(m);
    mm += m.squaredNorm();
  }
  const double a = em / mm;
  std::string out;
  for (int ring : {1, 2}) {
    double er = 0, mr = 0, ee = 0, mmr = 0, em_r = 0;
    int n = 0;
    for (size_t k = 0; k < pairs.size(); ++k) {
      if (rings[k] != ring) continue;
      const double x = pairs[k].first.dot(radials[k]), y = a * pairs[k].second.dot(radials[k]);
      er += x;
      mr += y;
      ee += x * x;
      mmr += y * y;
      em_r += x * y;
      ++n;
    }
    if (n == 0) continue;
    const double cov = em_r / n - er / n * mr / n, vx = ee / n - er * er / n / n,
                 vy = mmr / n - mr * mr / n / n;
    io::AppendFormat(&out, "  curvature model (a = %.3f): ring %d measured radial %+.4f, "
                     "predicted %+.4f, per-corner correlation %.2f\n", a, ring, er / n, mr / n,
                     cov / std::sqrt(vx * vy));
  }
  return out;
}

std::string PixelAgreementText(const BiasSetup& s, const cv::Mat& render, const cv::Mat& oracle,
                               cv::Mat* diff) {
  const cv::Mat inv = 255 - oracle;
  double d0 = 0, d1 = 0, n = 0, sd0 = 0, sd1 = 0;
  for (const auto& w : s.windows) {
    d0 += cv::norm(render(w.box), oracle(w.box), cv::NORM_L1);
    d1 += cv::norm(render(w.box), inv(w.box), cv::NORM_L1);
    cv::Mat a, b, c;
    render(w.box).convertTo(a, CV_64F);
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
        sum[k] += render.at<uchar>(v, u) - o;
        ++cnt[k];
      }
    }
  }
  cv::Mat a, b, full;
  render.convertTo(a, CV_32F);
  ref.convertTo(b, CV_32F);
  full = 128 + 4 * (a - b);  // 4x the difference around mid grey
  full.convertTo(full, CV_8U);
  *diff = full(s.windows[0].box);
  std::string out;
  io::AppendFormat(&out, "  mean diff on oracle-black %+.3f (%.0f px), white %+.3f (%.0f px), "
                   "edge %+.3f (%.0f px)\n", sum[0] / std::max(1.0, cnt[0]), cnt[0],
                   sum[1] / std::max(1.0, cnt[1]), cnt[1], sum[2] / std::max(1.0, cnt[2]), cnt[2]);
  io::AppendFormat(&out, "  pixels vs oracle (%s parity): mean |diff| %.2f grey levels, mean "
                   "diff %+.3f\n", same ? "same" : "inverted", (same ? d0 : d1) / n,
                   (same ? sd0 : sd1) / n);
  return out;
}

}  // namespace omni::synthetic
