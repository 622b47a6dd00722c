#include "detectors/lips/post_bands.h"

#include <algorithm>
#include <cmath>

namespace omni::detectors {
namespace {

float Median(std::vector<float>* v) {
  if (v->empty()) return 0;
  std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
  return (*v)[v->size() / 2];
}

// A band's core: its bins less one at each end where it is wide enough (its edge bins hold the
// edges' blur, part room), as [first, last] (last may pass bins: the caller wraps).
void Core(int lo, int width, int* first, int* last) {
  const int trim = width >= 5 ? 1 : 0;
  *first = lo + trim;
  *last = lo + width - 1 - trim;
}

// The band's own level per elevation (the mean over its core), -1 where a core bin is not seen.
std::vector<float> BandLevels(const RingGrid& grid, int first, int last) {
  std::vector<float> level(grid.elevations, 0);
  for (int j = 0; j < grid.elevations; ++j) {
    double sum = 0;
    for (int b = first; b <= last; ++b) {
      const float g = grid.at(b, j);
      if (g < 0) {
        sum = -1;
        break;
      }
      sum += g;
    }
    level[j] = sum < 0 ? -1.0f : static_cast<float>(sum / (last - first + 1));
  }
  return level;
}

// median_j |level(j) - grid(bin, j)| over the elevations both see; -1 with fewer than half.
float MedianDifference(const RingGrid& grid, const std::vector<float>& level, int bin, std::vector<float>* scratch) {
  scratch->clear();
  for (int j = 0; j < grid.elevations; ++j) {
    const float g = grid.at(bin, j);
    if (g >= 0 && level[j] >= 0) scratch->push_back(std::abs(level[j] - g));
  }
  if (2 * static_cast<int>(scratch->size()) < grid.elevations) return -1;
  return Median(scratch);
}

}  // namespace

BandScores ScoreBands(const RingGrid& grid, int min_width, int max_width, int gap, double noise_floor) {
  BandScores out;
  out.bins = grid.bins;
  out.min_width = min_width;
  out.max_width = max_width;
  const int widths = max_width - min_width + 1;
  out.scores.assign(static_cast<size_t>(grid.bins) * widths, 0.0f);
  // Each bin's mean step along the elevations (-1: fewer than half the steps seen), and its prefix
  // sums over two turns (bands wrap).
  const int B = grid.bins;
  std::vector<double> step(B, -1);
  for (int b = 0; b < B; ++b) {
    double sum = 0;
    int n = 0;
    for (int j = 1; j < grid.elevations; ++j) {
      const float a = grid.at(b, j - 1), c = grid.at(b, j);
      if (a < 0 || c < 0) continue;
      sum += std::abs(c - a);
      ++n;
    }
    if (2 * n >= grid.elevations) step[b] = sum / n;
  }
  std::vector<double> step_sum(2 * B + 1, 0);
  std::vector<int> unseen(2 * B + 1, 0);
  for (int k = 0; k < 2 * B; ++k) {
    step_sum[k + 1] = step_sum[k] + std::max(0.0, step[k % B]);
    unseen[k + 1] = unseen[k] + (step[k % B] < 0 ? 1 : 0);
  }
  // Per elevation, the levels' prefix sums over two turns (a band's level in O(1)).
  std::vector<std::vector<double>> level_sum(grid.elevations, std::vector<double>(2 * B + 1, 0));
  for (int j = 0; j < grid.elevations; ++j) {
    for (int k = 0; k < 2 * B; ++k) level_sum[j][k + 1] = level_sum[j][k] + grid.at(k % B, j);
  }
  std::vector<float> left, right;
  for (int lo = 0; lo < B; ++lo) {
    for (int width = min_width; width <= max_width; ++width) {
      int first = 0, last = 0;
      Core(lo, width, &first, &last);
      const int n = last - first + 1;
      if (unseen[last + 1] - unseen[first] > 0) continue;
      const double roughness = (step_sum[last + 1] - step_sum[first]) / n;
      left.clear();
      right.clear();
      const int side_left = lo - gap, side_right = lo + width - 1 + gap;
      for (int j = 0; j < grid.elevations; ++j) {
        // A band whose core misses an elevation (a -1 in the sum) is not compared there.
        bool seen = true;
        for (int b : {first, last}) seen = seen && grid.at(b, j) >= 0;
        if (!seen) continue;
        const double level = (level_sum[j][last + 1] - level_sum[j][first]) / n;
        const float l = grid.at(side_left, j), r = grid.at(side_right, j);
        if (l >= 0) left.push_back(static_cast<float>(std::abs(level - l)));
        if (r >= 0) right.push_back(static_cast<float>(std::abs(level - r)));
      }
      if (2 * static_cast<int>(std::min(left.size(), right.size())) < grid.elevations) continue;
      const double contrast = std::min(Median(&left), Median(&right));
      out.scores[static_cast<size_t>(lo) * widths + (width - min_width)] =
          static_cast<float>(contrast / (roughness + noise_floor));
    }
  }
  return out;
}

BandScores MedianScores(const std::vector<BandScores>& photos) {
  BandScores out;
  if (photos.empty()) return out;
  out = photos.front();
  std::vector<float> values(photos.size());
  for (size_t i = 0; i < out.scores.size(); ++i) {
    for (size_t p = 0; p < photos.size(); ++p) values[p] = photos[p].scores[i];
    // The lower median: with two photos a band must score in both.
    std::sort(values.begin(), values.end());
    out.scores[i] = values[(values.size() - 1) / 2];
  }
  return out;
}

std::vector<Band> BestBands(const BandScores& scores, int gap, double floor, int most) {
  std::vector<Band> out;
  const int B = scores.bins;
  std::vector<bool> taken(B, false);
  const auto wrap = [B](int b) { return ((b % B) + B) % B; };
  while (static_cast<int>(out.size()) < most) {
    Band best;
    for (int lo = 0; lo < B; ++lo) {
      for (int width = scores.min_width; width <= scores.max_width; ++width) {
        const float s = scores.score(lo, width);
        if (s < floor || s <= best.score) continue;
        bool free = true;
        for (int b = lo; b < lo + width && free; ++b) free = !taken[wrap(b)];
        if (free) best = Band{lo, width, s};
      }
    }
    if (best.score <= 0) break;
    for (int b = best.lo - gap; b < best.lo + best.width + gap; ++b) taken[wrap(b)] = true;
    out.push_back(best);
  }
  return out;
}

Band BestBandNear(const BandScores& scores, double centre, int reach, int min_width, int max_width) {
  Band best;
  const int B = scores.bins;
  for (int lo = 0; lo < B; ++lo) {
    for (int width = std::max(min_width, scores.min_width); width <= std::min(max_width, scores.max_width); ++width) {
      const double c = lo + 0.5 * width;
      const double off = std::remainder(c - centre, static_cast<double>(B));
      if (std::abs(off) > reach) continue;
      const float s = scores.score(lo, width);
      if (s > best.score) best = Band{lo, width, s};
    }
  }
  return best;
}

BandEdges PlaceBandEdges(const RingGrid& grid, const Band& band, int gap) {
  BandEdges out;
  int first = 0, last = 0;
  Core(band.lo, band.width, &first, &last);
  const std::vector<float> level = BandLevels(grid, first, last);
  // d[k]: the median difference from the band's level at bin lo - reach + k.
  const int reach = gap + std::max(band.width, 4);
  const int start = band.lo - reach, end = band.lo + band.width - 1 + reach;
  std::vector<float> d, scratch;
  for (int b = start; b <= end; ++b) d.push_back(MedianDifference(grid, level, b, &scratch));
  const auto at = [&](int b) { return d[b - start]; };
  std::vector<float> inside, beyond_left, beyond_right;
  for (int b = first; b <= last; ++b) {
    if (at(b) >= 0) inside.push_back(at(b));
  }
  for (int b = start; b <= band.lo - gap; ++b) {
    if (at(b) >= 0) beyond_left.push_back(at(b));
  }
  for (int b = band.lo + band.width - 1 + gap; b <= end; ++b) {
    if (at(b) >= 0) beyond_right.push_back(at(b));
  }
  if (inside.empty() || beyond_left.empty() || beyond_right.empty()) return out;
  const float d_in = Median(&inside);
  const float half_left = 0.5f * (d_in + Median(&beyond_left)), half_right = 0.5f * (d_in + Median(&beyond_right));
  // Too little contrast to place an edge by (3 grey levels: the noise of a camera's flat patch).
  constexpr float kMinStep = 3.0f;
  if (half_left - d_in < 0.5f * kMinStep || half_right - d_in < 0.5f * kMinStep) return out;
  // Walking out from the band's middle: the first bin at or over the half-way level, the crossing
  // interpolated from the bin before it (bin b's centre at b + 0.5).
  const int middle = band.lo + band.width / 2;
  bool found_left = false, found_right = false;
  for (int b = middle - 1; b >= start; --b) {
    if (at(b) < 0 || at(b + 1) < 0) break;
    if (at(b) >= half_left) {
      const double t = (at(b + 1) < half_left) ? (half_left - at(b + 1)) / (at(b) - at(b + 1)) : 0.0;
      out.left = b + 1.5 - t;
      found_left = true;
      break;
    }
  }
  for (int b = middle + 1; b <= end; ++b) {
    if (at(b) < 0 || at(b - 1) < 0) break;
    if (at(b) >= half_right) {
      const double t = (at(b - 1) < half_right) ? (half_right - at(b - 1)) / (at(b) - at(b - 1)) : 0.0;
      out.right = b - 0.5 + t;
      found_right = true;
      break;
    }
  }
  out.ok = found_left && found_right && out.right > out.left;
  return out;
}

}  // namespace omni::detectors
