// A post of the mount as a band in one ring of one photo (post_finder.h samples the rings; this
// scores and places the bands, on grids alone, so that drawn grids test it).
//
// A ring sampled per azimuth bin along its elevations is a grid levels[bin][elevation]; a post
// is a band of bins whose columns are one plain surface (the same level all along the ring's
// elevations, up to noise) and differ from the columns just beside it. Its score is that
// difference over the band's own roughness:
//   contrast  = the smaller over both sides of median_j |band(j) - side(j)|
//   roughness = the band's mean step between successive elevations
//   score     = contrast / (roughness + noise_floor)
// A textured room: the band is flat and the room is not (roughness tells). A plain room: the room
// is as flat as the post, and the contrast tells (a grey post on a grey wall of the same level is
// not seen). A dark or a light post alike: the contrast is unsigned. Wider bands than the post
// take in the room (rougher), narrower ones compare the post with itself (no contrast): the best
// band is the post, up to the sides' gap, which the edges' half-way crossings then place.
#pragma once

#include <cstddef>
#include <vector>

namespace omni::detectors {

// One photo's ring: levels[bin * elevations + j], grey levels (0-255), -1 where not seen.
struct RingGrid {
  int bins = 0, elevations = 0;
  std::vector<float> levels;
  float at(int bin, int j) const { return levels[static_cast<std::size_t>(Wrap(bin)) * elevations + j]; }
  int Wrap(int bin) const { return ((bin % bins) + bins) % bins; }
};

// The scores of every band [lo, lo + width) for widths in [min_width, max_width] bins, the sides
// `gap` bins beyond its ends (past the edges' blur); score(lo, width), 0 where too few elevations
// see the band and its sides (a ring's edge, a model whose ring does not reach).
struct BandScores {
  int bins = 0, min_width = 0, max_width = 0;
  std::vector<float> scores;
  float score(int lo, int width) const {
    return scores[static_cast<std::size_t>(lo) * (max_width - min_width + 1) + (width - min_width)];
  }
};
BandScores ScoreBands(const RingGrid& grid, int min_width, int max_width, int gap, double noise_floor);

// The median over photos of each band's score (all of the same shape).
BandScores MedianScores(const std::vector<BandScores>& photos);

struct Band {
  int lo = 0, width = 0;  // bins
  double score = 0;
};

// The best bands, non-overlapping (each keeps `gap` bins clear of the others), best first, at
// most `most`, none under `floor`.
std::vector<Band> BestBands(const BandScores& scores, int gap, double floor, int most);

// The best band whose centre lies within `reach` bins of `centre` and whose width is in
// [min_width, max_width] (the other ring's view of a post: a model not yet calibrated registers
// the rings a few degrees apart). Score 0 if none.
Band BestBandNear(const BandScores& scores, double centre, int reach, int min_width, int max_width);

// A band's edges in one photo, in bins (continuous: bin b's centre at b + 0.5): where, walking out
// from the band, the median over elevations of |level - the band's own level| crosses half way
// from its value inside the band to its value beyond the edge. ok false where a side has no
// contrast to cross (the band's level continues) or too few elevations.
struct BandEdges {
  bool ok = false;
  double left = 0, right = 0;
};
BandEdges PlaceBandEdges(const RingGrid& grid, const Band& band, int gap);

}  // namespace omni::detectors
