#include "health/residuals.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <opencv2/core.hpp>

#include "model/lip.h"

namespace omni::health {
namespace {

constexpr double kTwoPi = 2 * M_PI;

struct Bin {
  std::string kind;
  double azimuth_deg = 0;
  std::vector<int> members;  // indices into the samples
  std::optional<LipReferenceBin> reference;
};

// The mean of a bin's samples within 3 robust sigmas of their median, and its standard error;
// *members keeps those samples, which are marked kept.
double RobustMean(std::vector<Sample>* samples, std::vector<int>* members, double* se) {
  std::vector<double> v;
  for (int i : *members) v.push_back((*samples)[i].value);
  std::vector<double> sorted = v;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  std::vector<double> dev;
  for (double x : v) dev.push_back(std::abs(x - median));
  std::nth_element(dev.begin(), dev.begin() + dev.size() / 2, dev.end());
  const double spread = std::max(1.4826 * dev[dev.size() / 2], 1e-3);
  std::vector<int> kept;
  double sum = 0, sum2 = 0;
  for (size_t k = 0; k < v.size(); ++k) {
    if (std::abs(v[k] - median) > 3 * spread) continue;
    kept.push_back((*members)[k]);
    sum += v[k];
    sum2 += v[k] * v[k];
  }
  const double n = static_cast<double>(kept.size());
  const double mean = sum / n;
  const double var = n > 1 ? std::max(0.0, (sum2 - n * mean * mean) / (n - 1)) : 0;
  *se = std::sqrt(var / n);
  for (int i : kept) (*samples)[i].kept = true;
  *members = kept;
  return mean;
}


}  // namespace

int AzimuthBin(double angle, int bins) {
  angle = std::fmod(angle, kTwoPi);
  if (angle < 0) angle += kTwoPi;
  return std::min(bins - 1, static_cast<int>(angle / kTwoPi * bins));
}

std::optional<double> ResidualUnder(const RigModel& model, const Sample& s) {
  if (s.is_match) {
    double w = s.w;
    return EpipolarGap(model, s.pixel1, s.pixel2, &w);
  }
  const auto lip = LipResidualUnder(model, s.lip);
  if (!lip) return std::nullopt;
  return *lip - s.reference;
}

namespace {

// Every ring-to-ring match as a sample, binned by azimuth and by elevation above or below their
// median (bin 2 a + 0 / 1).
void AddMatchSamples(const std::vector<ImageEvidence>& images, int nb,
                     std::vector<Sample>* samples) {
  const size_t first = samples->size();
  std::vector<double> elevations;
  for (size_t k = 0; k < images.size(); ++k) {
    for (const RingMatch& m : images[k].matches) {
      Sample s;
      s.image = static_cast<int>(k);
      s.pixel1 = m.pixel1;
      s.pixel2 = m.pixel2;
      s.bin = AzimuthBin(m.azimuth, nb) * 2;
      s.value = m.elevation;  // for the split below
      samples->push_back(s);
      elevations.push_back(m.elevation);
    }
  }
  double elevation_split = 0;
  if (!elevations.empty()) {
    std::nth_element(elevations.begin(), elevations.begin() + elevations.size() / 2,
                     elevations.end());
    elevation_split = elevations[elevations.size() / 2];
  }
  for (size_t i = first; i < samples->size(); ++i) {
    Sample& s = (*samples)[i];
    s.bin += s.value < elevation_split ? 0 : 1;
  }
}

// A spread subsample of each lip edge's points (bin 1000 + the edge's id; the azimuth bin is
// added once phi is known).
void AddLipSamples(const std::vector<ImageEvidence>& images, const CheckOptions& options,
                   std::vector<Sample>* samples) {
  std::map<std::pair<LipPath, LipCircle>, int> edge_ids;
  for (size_t image = 0; image < images.size(); ++image) {
    for (const LipEdgeObservation& edge : images[image].lips) {
      if (!edge.path || !edge.circle || edge.points.empty()) continue;
      const auto key = std::make_pair(*edge.path, *edge.circle);
      const int id = edge_ids.emplace(key, static_cast<int>(edge_ids.size())).first->second;
      const size_t stride =
          std::max<size_t>(1, edge.points.size() / options.max_lip_points_per_edge);
      for (size_t k = 0; k < edge.points.size(); k += stride) {
        Sample s;
        s.is_match = false;
        s.image = static_cast<int>(image);
        s.lip.path = key.first;
        s.lip.circle = key.second;
        s.lip.pixel = edge.points[k];
        s.bin = 1000 + id;  // the azimuth bin is added once phi is known
        samples->push_back(s);
      }
    }
  }
}

// The valid samples in their bins (lip samples' bins get their azimuth here, and their
// reference); counts in `set`.
std::map<int, Bin> BinSamples(int nb, const LipReference& reference, SampleSet* set) {
  std::vector<Sample>& samples = set->samples;
  std::map<int, Bin> bins;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (!samples[i].valid) continue;
    Sample& s = samples[i];
    if (s.is_match) {
      ++set->n_matches;
      Bin& b = bins[s.bin];
      b.kind = "matches";
      b.azimuth_deg = (s.bin / 2 + 0.5) * 360.0 / nb;
      b.members.push_back(static_cast<int>(i));
    } else {
      ++set->n_lip_points;
      const int id = s.bin - 1000;
      s.bin = 1000 + id * nb + AzimuthBin(s.lip.phi, nb);
      Bin& b = bins[s.bin];
      b.kind = std::string(LipPathName(s.lip.path)) + " " + LipCircleName(s.lip.circle);
      b.azimuth_deg = (AzimuthBin(s.lip.phi, nb) + 0.5) * 360.0 / nb;
      b.members.push_back(static_cast<int>(i));
      if (const LipReferenceBin* r = reference.Find(b.kind, AzimuthBin(s.lip.phi, nb))) {
        s.reference = r->mean_px;
        s.value -= s.reference;
        b.reference = *r;
      }
    }
  }

  return bins;
}

// Robust bin means; bins too thin to estimate are dropped. Each bin's standard error comes
// from the scatter about the bin means pooled over its kind (a bin of 15 lip points would
// otherwise estimate its own spread badly: t-distributed, chi^2 17% high), widened by the kind's
// floor; a bin measured from the calibration photos' (lip_reference.h) has the error of a
// difference of two means of photos, tau^2 / photos + tau^2 / reference photos with tau the
// scatter of one photo's mean (its points' own noise is in tau; the larger of the two counts
// where this photo's points are fewer), and the floor.
void EstimateBins(std::map<int, Bin>* bins_in, const CheckOptions& options, SampleSet* set) {
  std::map<int, Bin>& bins = *bins_in;
  std::vector<Sample>& samples = set->samples;
  std::vector<Bin*> used;
  std::vector<double> means;
  for (Sample& s : samples) s.kept = false;
  std::map<std::string, std::pair<double, int>> pooled;  // kind: sum of squares, dof
  for (auto& [key, bin] : bins) {
    if (static_cast<int>(bin.members.size()) < options.min_bin_count) continue;
    double se = 0;
    const double mean = RobustMean(&samples, &bin.members, &se);
    if (static_cast<int>(bin.members.size()) < options.min_bin_count) continue;
    used.push_back(&bin);
    means.push_back(mean);
    auto& [ss, dof] = pooled[bin.kind];
    for (int i : bin.members) ss += (samples[i].value - mean) * (samples[i].value - mean);
    dof += static_cast<int>(bin.members.size()) - 1;
  }
  for (size_t b = 0; b < used.size(); ++b) {
    const auto& [ss, dof] = pooled[used[b]->kind];
    const double sd = std::sqrt(ss / std::max(dof, 1));
    set->kind_sd[used[b]->kind] = sd;
    const double floor =
        used[b]->kind == "matches" ? options.match_floor_px : options.lip_floor_px;
    SampleBin bin;
    bin.kind = used[b]->kind;
    bin.azimuth_deg = used[b]->azimuth_deg;
    bin.members = used[b]->members;
    bin.mean = means[b];
    std::set<int> photos;
    for (int i : bin.members) photos.insert(samples[i].image);
    bin.photos = static_cast<int>(photos.size());
    const double points_se = sd / std::sqrt(static_cast<double>(bin.members.size()));
    bin.reference = used[b]->reference;
    if (bin.reference) {
      // The floor stays: what the edge's bias owes to the scene behind it is not learnt from
      // calibration photos of one room (a clean render's 8 photos scatter by 0.00 px).
      const double tau2 = bin.reference->scatter_px * bin.reference->scatter_px;
      bin.standard_error = std::sqrt(std::max(points_se * points_se, tau2 / bin.photos) +
                                     tau2 / bin.reference->photos + floor * floor);
    } else {
      bin.standard_error = std::hypot(points_se, floor);
    }
    set->bins.push_back(bin);
  }
  // Samples of dropped bins are not kept.
  std::vector<bool> in_used(samples.size(), false);
  for (const SampleBin& bin : set->bins) {
    for (int i : bin.members) in_used[i] = true;
  }
  for (size_t i = 0; i < samples.size(); ++i) samples[i].kept = samples[i].kept && in_used[i];
}

}  // namespace

SampleSet CollectSamples(const RigModel& model, const std::vector<ImageEvidence>& images,
                         const CheckOptions& options, const LipReference& reference) {
  SampleSet set;
  const int nb = options.azimuth_bins;
  // Samples: every match, a spread subsample of each lip edge's points.
  std::vector<Sample>& samples = set.samples;
  AddMatchSamples(images, nb, &samples);
  AddLipSamples(images, options, &samples);
  // Residuals under the stored model (parallel: a lip point's nearest edge point takes ~0.3 ms).
  cv::parallel_for_(cv::Range(0, static_cast<int>(samples.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      Sample& s = samples[i];
      if (s.is_match) {
        const auto gap = EpipolarGap(model, s.pixel1, s.pixel2, &s.w);
        if (gap) s.value = *gap, s.valid = true;
      } else {
        const auto lip = LipResidual(model, s.lip.path, s.lip.circle, s.lip.pixel);
        if (lip) s.lip = *lip, s.value = lip->value, s.valid = true;
      }
    }
  });
  std::map<int, Bin> bins = BinSamples(nb, reference, &set);
  EstimateBins(&bins, options, &set);
  return set;
}

}  // namespace omni::health
