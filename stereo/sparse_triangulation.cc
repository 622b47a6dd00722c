#include "stereo/sparse_triangulation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include <Eigen/Cholesky>

namespace omni::stereo {

std::vector<CornerPair> PairCorners(const Triangulator& triangulator, int image,
                                    const std::vector<CornerObservation>& corners,
                                    double max_gap_fraction) {
  // The azimuth of each observation's ray (0 where it does not back-project: never paired).
  std::vector<double> azimuth(corners.size(), 0.0);
  std::vector<char> ok(corners.size(), 0);
  for (size_t i = 0; i < corners.size(); ++i) {
    const auto ray = triangulator.model().Unproject(corners[i].pixel);
    if (!ray || ray->mirror != corners[i].mirror) continue;
    azimuth[i] = std::atan2(ray->ray.direction.y(), ray->ray.direction.x());
    ok[i] = 1;
  }
  // Candidates: every (mirror 1, mirror 2) observation pair with the same (target, id).
  std::map<std::pair<int, int>, std::vector<int>> ring1, ring2;
  for (int i = 0; i < static_cast<int>(corners.size()); ++i) {
    if (!ok[i]) continue;
    const auto key = std::make_pair(corners[i].target, corners[i].id);
    (corners[i].mirror == Mirror::kOne ? ring1 : ring2)[key].push_back(i);
  }
  struct Candidate {
    double azimuth_difference;
    int i1, i2;
  };
  std::vector<Candidate> candidates;
  for (const auto& [key, list1] : ring1) {
    const auto it = ring2.find(key);
    if (it == ring2.end()) continue;
    for (int i1 : list1) {
      for (int i2 : it->second) {
        const double difference =
            std::abs(std::remainder(azimuth[i1] - azimuth[i2], 2 * M_PI));
        if (difference > kMaxPairAzimuthDifference) continue;
        double gap = 0;
        const auto p = triangulator.Midpoint(corners[i1].pixel, corners[i2].pixel, &gap);
        if (!p) continue;
        if (gap / std::max(1.0, p->head<2>().norm()) <= max_gap_fraction) {
          candidates.push_back({difference, i1, i2});
        }
      }
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.azimuth_difference < b.azimuth_difference;
  });
  std::vector<char> used(corners.size(), 0);
  std::vector<CornerPair> pairs;
  for (const Candidate& c : candidates) {
    if (used[c.i1] || used[c.i2]) continue;
    used[c.i1] = used[c.i2] = 1;
    pairs.push_back({image, corners[c.i1].target, corners[c.i1].id, corners[c.i1].pixel,
                     corners[c.i2].pixel});
  }
  return pairs;
}

std::vector<double> RangeBins(const Truth& truth) {
  std::vector<double> ranges;
  for (const auto& image : truth.images) {
    for (const auto& t : image.placement_translation) ranges.push_back(t.head<2>().norm());
  }
  std::sort(ranges.begin(), ranges.end());
  std::vector<double> bins;
  std::vector<int> counts;
  for (double r : ranges) {
    if (!bins.empty() && r <= 1.1 * bins.back() / counts.back()) {
      bins.back() += r;
      ++counts.back();
    } else {
      bins.push_back(r);
      counts.push_back(1);
    }
  }
  for (size_t i = 0; i < bins.size(); ++i) bins[i] /= counts[i];
  return bins;
}

namespace {

double NearestBin(const std::vector<double>& bins, double range) {
  double best = range, best_d = INFINITY;
  for (double b : bins) {
    const double d = std::abs(std::log(range / b));
    if (d < best_d) best_d = d, best = b;
  }
  return best;
}

}  // namespace

std::vector<CornerPair> TruthPairs(const Truth& truth, double noise_px, std::mt19937* rng,
                                   double noise_px_ring2) {
  std::normal_distribution<double> unit(0.0, 1.0);
  const double sigma2 = noise_px_ring2 >= 0 ? noise_px_ring2 : noise_px;
  auto jitter = [&](double sigma) {
    return sigma > 0 ? Eigen::Vector2d(sigma * unit(*rng), sigma * unit(*rng))
                     : Eigen::Vector2d::Zero();
  };
  std::vector<CornerPair> pairs;
  for (int i = 0; i < static_cast<int>(truth.images.size()); ++i) {
    for (const TruthCorner& c : truth.images[i].corners) {
      if (!c.pixel[0] || !c.pixel[1]) continue;
      const Eigen::Vector2d px1 = *c.pixel[0] + jitter(noise_px);
      const Eigen::Vector2d px2 = *c.pixel[1] + jitter(sigma2);
      pairs.push_back({i, c.target, c.id, px1, px2});
    }
  }
  return pairs;
}


// A detected corner farther than this from the true pixel (in either ring) has no true corner.
constexpr double kMaxPixelDistance = 3.0;

std::optional<CornerError> CompareWithTruth(const Truth& truth,
                                            const std::vector<double>& range_bins_mm,
                                            const CornerPair& pair,
                                            const TriangulatedPoint& estimate) {
  if (pair.image < 0 || pair.image >= static_cast<int>(truth.images.size())) return std::nullopt;
  const TruthImage& image = truth.images[pair.image];
  const std::optional<Eigen::Vector2d> pixels[2] = {pair.pixel1, pair.pixel2};
  // Any target: see the header.
  const TruthCorner* best =
      NearestTrueCorner(image.corners, pixels, kMaxPixelDistance,
                        [&](const TruthCorner& c) { return c.id == pair.id; }).corner;
  if (!best) return std::nullopt;
  CornerError e;
  e.range_bin_mm = NearestBin(range_bins_mm,
                              image.placement_translation[best->placement].head<2>().norm());
  e.error = estimate.point_in_cam - best->point_in_cam;
  e.covariance = estimate.covariance;
  e.pixel_error << pair.pixel1 - *best->pixel[0], pair.pixel2 - *best->pixel[1];
  e.jacobian_px = estimate.jacobian_px;
  e.model_covariance = estimate.model_covariance;
  return e;
}

namespace {

// Mean e^T Sigma^-1 e over the points whose Sigma is positive definite (NAN if none).
template <typename CovarianceOf>
double MeanNees(const std::vector<const CornerError*>& list, CovarianceOf covariance_of) {
  double nees = 0;
  int n = 0;
  for (const CornerError* e : list) {
    const Eigen::Matrix3d sigma = covariance_of(*e);
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(sigma);
    if (sigma.trace() > 0 && ldlt.info() == Eigen::Success && ldlt.isPositive()) {
      nees += e->error.dot(ldlt.solve(e->error));
      ++n;
    }
  }
  return n > 0 ? nees / n : NAN;
}

}  // namespace

std::vector<RangeRow> RangeTable(const std::vector<CornerError>& errors) {
  std::map<double, std::vector<const CornerError*>> by_bin;
  for (const auto& e : errors) by_bin[e.range_bin_mm].push_back(&e);
  std::vector<RangeRow> rows;
  for (const auto& [range, list] : by_bin) {
    RangeRow row;
    row.range_mm = range;
    row.points = static_cast<int>(list.size());
    double sum2 = 0, sum = 0, sigma = 0, px2[2] = {0, 0};
    for (const CornerError* e : list) {
      const double n = e->error.norm();
      sum += n;
      sum2 += n * n;
      sigma += std::sqrt(std::max(0.0, e->covariance.trace()));
      px2[0] += e->pixel_error.head<2>().squaredNorm();
      px2[1] += e->pixel_error.tail<2>().squaredNorm();
    }
    for (int m = 0; m < 2; ++m) row.pixel_rms_px[m] = std::sqrt(px2[m] / (2.0 * row.points));
    const Eigen::Vector4d omega(px2[0], px2[0], px2[1], px2[1]);  // per coordinate, below / 2n
    row.mean_nees = MeanNees(list, [](const CornerError& e) { return e.covariance; });
    row.mean_nees_measured = MeanNees(list, [&](const CornerError& e) -> Eigen::Matrix3d {
      return e.jacobian_px * (omega / (2.0 * row.points)).asDiagonal() *
                 e.jacobian_px.transpose() + e.model_covariance;
    });
    const double mean = sum / row.points;
    row.rmse_mm = std::sqrt(sum2 / row.points);
    row.sd_mm = row.points > 1
                    ? std::sqrt(std::max(0.0, (sum2 - row.points * mean * mean) / (row.points - 1)))
                    : 0.0;
    row.mean_sigma_mm = sigma / row.points;
    rows.push_back(row);
  }
  return rows;
}

namespace {

// The reference row within 10% of this range, or nullptr.
const ReferenceRow* ReferenceAt(const std::vector<ReferenceRow>& reference, double range_mm) {
  for (const ReferenceRow& r : reference) {
    if (std::abs(range_mm / 1000.0 - r.range_m) < 0.1 * r.range_m) return &r;
  }
  return nullptr;
}

}  // namespace

std::string FormatRangeTable(const std::vector<RangeRow>& rows,
                             const std::vector<ReferenceRow>& reference) {
  std::string out =
      "range_m  rmse_mm    sd_mm  points   ref_rmse   ref_sd  sigma_mm  mean_nees  "
      "px_rms_1 px_rms_2  nees_at_px_rms\n";
  char line[200];
  for (const RangeRow& r : rows) {
    std::string reference_text = "        -        -";
    if (const ReferenceRow* ref = ReferenceAt(reference, r.range_mm)) {
      char p[48];
      std::snprintf(p, sizeof(p), "%9.2f %8.2f", ref->rmse_mm, ref->sd_mm);
      reference_text = p;
    }
    std::snprintf(line, sizeof(line), "%7.3f %8.3f %8.3f %7d  %s %9.3f %10.2f %9.3f %8.3f %15.2f\n",
                  r.range_mm / 1000.0, r.rmse_mm, r.sd_mm, r.points, reference_text.c_str(),
                  r.mean_sigma_mm, r.mean_nees, r.pixel_rms_px[0], r.pixel_rms_px[1],
                  r.mean_nees_measured);
    out += line;
  }
  return out;
}

std::vector<SeedSpreadRow> SeedSpread(const Triangulator& triangulator, const Truth& truth,
                                      double noise_px, double noise_px_ring2, int seeds,
                                      unsigned first_seed, const TriangulationOptions& options) {
  struct Bin {
    int points = 0;
    double predicted2 = 0, sum2 = 0;
    long n = 0;
    std::vector<double> per_seed;
  };
  std::map<double, Bin> bins;
  const std::vector<double> range_bins = RangeBins(truth);
  const double s2 = noise_px_ring2 >= 0 ? noise_px_ring2 : noise_px;
  const Eigen::Vector4d omega(noise_px * noise_px, noise_px * noise_px, s2 * s2, s2 * s2);
  // The prediction: A at the exact pixels.
  std::mt19937 unused(0);
  for (const CornerPair& pair : TruthPairs(truth, 0.0, &unused)) {
    const auto point = triangulator.Triangulate(pair.pixel1, pair.pixel2, options);
    if (!point) continue;
    const auto e = CompareWithTruth(truth, range_bins, pair, *point);
    if (!e) continue;
    Bin& bin = bins[e->range_bin_mm];
    ++bin.points;
    bin.predicted2 += (e->jacobian_px * omega.asDiagonal() * e->jacobian_px.transpose()).trace();
  }
  for (int s = 0; s < seeds; ++s) {
    std::mt19937 rng(first_seed + static_cast<unsigned>(s));
    std::map<double, std::pair<double, int>> run;  // sum of |e|^2, points
    for (const CornerPair& pair : TruthPairs(truth, noise_px, &rng, s2)) {
      const auto point = triangulator.Triangulate(pair.pixel1, pair.pixel2, options);
      if (!point) continue;
      const auto e = CompareWithTruth(truth, range_bins, pair, *point);
      if (!e) continue;
      run[e->range_bin_mm].first += e->error.squaredNorm();
      ++run[e->range_bin_mm].second;
    }
    for (const auto& [range, sums] : run) {
      Bin& bin = bins[range];
      bin.sum2 += sums.first;
      bin.n += sums.second;
      bin.per_seed.push_back(std::sqrt(sums.first / sums.second));
    }
  }
  std::vector<SeedSpreadRow> rows;
  for (auto& [range, bin] : bins) {
    if (bin.per_seed.empty() || bin.points == 0) continue;
    std::sort(bin.per_seed.begin(), bin.per_seed.end());
    auto percentile = [&](double q) {
      return bin.per_seed[static_cast<size_t>(std::lround(q * (bin.per_seed.size() - 1)))];
    };
    SeedSpreadRow row;
    row.range_mm = range;
    row.points = bin.points;
    row.predicted_rmse_mm = std::sqrt(bin.predicted2 / bin.points);
    row.rmse_mm = std::sqrt(bin.sum2 / bin.n);
    row.p05_mm = percentile(0.05);
    row.p50_mm = percentile(0.5);
    row.p95_mm = percentile(0.95);
    rows.push_back(row);
  }
  return rows;
}

std::string FormatSeedSpread(const std::vector<SeedSpreadRow>& rows,
                             const std::vector<ReferenceRow>& reference) {
  std::string out = "range_m  points predicted_rmse  rmse_all    p05_rmse  p50_rmse  p95_rmse    ref_rmse\n";
  char line[200];
  for (const SeedSpreadRow& r : rows) {
    char paper[16] = "         -";
    if (const ReferenceRow* ref = ReferenceAt(reference, r.range_mm)) {
      std::snprintf(paper, sizeof(paper), "%10.2f", ref->rmse_mm);
    }
    std::snprintf(line, sizeof(line), "%7.3f %7d %14.3f %9.3f %11.3f %9.3f %9.3f  %s\n",
                  r.range_mm / 1000.0, r.points, r.predicted_rmse_mm, r.rmse_mm, r.p05_mm,
                  r.p50_mm, r.p95_mm, paper);
    out += line;
  }
  return out;
}

TriangulatedPoint Moved(TriangulatedPoint p, const Pose<double>& to_from_cam) {
  const Eigen::Matrix3d& r = to_from_cam.rotation;
  p.point_in_cam = to_from_cam * p.point_in_cam;
  p.covariance = r * p.covariance * r.transpose();
  p.model_covariance = r * p.model_covariance * r.transpose();
  p.jacobian_px = r * p.jacobian_px;
  return p;
}

OutputFrames FramesOf(const RigParams& rig, ReferenceBody reference, const RigParams* true_rig) {
  const Pose<double> identity{Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()};
  OutputFrames frames{identity, identity};
  if (reference != ReferenceBody::kMirror1) return frames;
  const Pose<double> mirror1_from_cam = PoseFromBlock(rig.mirror1_pose.data()).Inverse();
  frames.out_from_cam = mirror1_from_cam;
  if (true_rig) {
    const Pose<double> true_cam_from_mirror1 = PoseFromBlock(true_rig->mirror1_pose.data());
    frames.true_cam_from_cam = {true_cam_from_mirror1.rotation * mirror1_from_cam.rotation,
                                true_cam_from_mirror1 * mirror1_from_cam.translation};
  }
  return frames;
}

SessionTriangulation TriangulatePairs(const Triangulator& triangulator,
                                      const std::vector<CornerPair>& pairs,
                                      const TriangulationOptions& options,
                                      const OutputFrames& frames, const Truth* truth) {
  SessionTriangulation out;
  const std::vector<double> range_bins = truth ? RangeBins(*truth) : std::vector<double>{};
  for (const auto& pair : pairs) {
    const auto point = triangulator.Triangulate(pair.pixel1, pair.pixel2, options);
    if (!point) {
      ++out.failed;
      continue;
    }
    out.points.push_back({pair, Moved(*point, frames.out_from_cam)});
    if (!truth) continue;
    if (auto e = CompareWithTruth(*truth, range_bins, pair, Moved(*point, frames.true_cam_from_cam))) {
      out.errors.push_back(*e);
    } else {
      ++out.unmatched;
    }
  }
  return out;
}

}  // namespace omni::stereo
