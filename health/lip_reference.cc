#include "health/lip_reference.h"

#include <algorithm>

#include "model/single_rim.h"

#include <cmath>

#include "health/residuals.h"

namespace omni::health {

LipReference::LipReference(const RigParams& stored, int azimuth_bins) {
  if (!stored.calibration || stored.calibration->lip_reference_sectors != azimuth_bins) return;
  for (const LipReferenceBin& bin : stored.calibration->lip_reference) {
    const int sector = AzimuthBin(bin.azimuth_deg * M_PI / 180, azimuth_bins);
    bins_[{bin.edge, sector}] = bin;
  }
}

const LipReferenceBin* LipReference::Find(const std::string& edge, int sector) const {
  const auto it = bins_.find({edge, sector});
  return it == bins_.end() ? nullptr : &it->second;
}

RigParams AsObserved(const RigParams& stored) {
  if (!stored.Single() || !stored.calibration || !(stored.calibration->lip_reference_edge_radius > 0)) {
    return stored;
  }
  return WithRimCircleAt(stored, stored.calibration->lip_reference_edge_radius);
}

std::vector<LipReferenceBin> LearnLipReference(const RigModel& model,
                                               const std::vector<ImageEvidence>& images,
                                               const CheckOptions& options, int min_photos) {
  if (static_cast<int>(images.size()) < min_photos) return {};
  std::vector<ImageEvidence> lips_only = images;
  for (ImageEvidence& image : lips_only) image.matches.clear();
  const SampleSet set = CollectSamples(model, lips_only, options);
  // A photo's mean in a bin needs a few points to say anything of that photo.
  const int min_points = std::max(3, options.min_bin_count / 2);
  struct Spread {
    std::vector<double> photo_means;
    double ss = 0;  // about the bin's mean
  };
  std::vector<Spread> spread(set.bins.size());
  std::map<std::string, std::pair<double, int>> pooled;  // edge: sum of squares, dof
  for (size_t b = 0; b < set.bins.size(); ++b) {
    const SampleBin& bin = set.bins[b];
    std::map<int, std::pair<double, int>> per_photo;  // image: sum, count
    for (int i : bin.members) {
      auto& [sum, n] = per_photo[set.samples[i].image];
      sum += set.samples[i].value;
      ++n;
    }
    for (const auto& [image, sum_n] : per_photo) {
      if (sum_n.second < min_points) continue;
      const double m = sum_n.first / sum_n.second;
      spread[b].photo_means.push_back(m);
      spread[b].ss += (m - bin.mean) * (m - bin.mean);
    }
    const int dof = static_cast<int>(spread[b].photo_means.size()) - 1;
    if (dof < 1) continue;
    pooled[bin.kind].first += spread[b].ss;
    pooled[bin.kind].second += dof;
  }
  std::vector<LipReferenceBin> reference;
  for (size_t b = 0; b < set.bins.size(); ++b) {
    const SampleBin& bin = set.bins[b];
    const int photos = static_cast<int>(spread[b].photo_means.size());
    if (photos < 2) continue;
    const auto& [pooled_ss, pooled_dof] = pooled[bin.kind];
    const double edge_var = pooled_ss / pooled_dof;
    const double var = (spread[b].ss + kPooledScatterPhotos * edge_var) /
                       (photos - 1 + kPooledScatterPhotos);
    LipReferenceBin r;
    r.edge = bin.kind;
    r.azimuth_deg = bin.azimuth_deg;
    r.photos = photos;
    r.mean_px = bin.mean;
    r.scatter_px = std::sqrt(var);
    reference.push_back(r);
  }
  return reference;
}

double RimSceneSigma(const RigParams& stored, const std::vector<ImageEvidence>& images,
                     const CheckOptions& options) {
  const double prior = options.rim_scene_prior_px;
  const int n = static_cast<int>(images.size());
  double ss = 0;
  int dof = 0;
  if (n >= 2) {
    for (const ImageEvidence& image : images) {
      const CheckResult one = CheckRig(stored, {image}, options);
      if (one.rim_move.size() != kRimHarmonics) continue;
      // Each photo's move is about the reference's mean, itself over these photos.
      ss += one.rim_move.squaredNorm() * n / (n - 1.0);
      dof += kRimHarmonics;
    }
  }
  const double prior_dof = kPooledScatterPhotos * kRimHarmonics;
  return std::sqrt((ss + prior_dof * prior * prior) / (dof + prior_dof));
}

}  // namespace omni::health
