// How large a lip edge's constant detector bias across the edge may be, from what its residuals
// show along the edge (calib/solve_covariance.cc LipEdgeColumns carries it as a considered column).
// The rig parameters absorb an edge's constant offset (its radius in the image is the camera-to-
// mirror scale f / Z), so the residuals cannot show it; what they show is the rest of the
// detector's systematic error along the edge (a band edge placed off the curve over some
// azimuths). Taken as a stationary pattern round the edge, its constant part is the mean of a
// correlated series: its sigma is the pattern's RMS times sqrt(correlation length / edge length).
// A pattern correlated over a few degrees averages round a whole edge; one that stays on one side
// for tens of degrees (the webcam's crescent edge seen via mirror 2) does not.
#ifndef OMNI_CALIB_LIP_EDGE_BIAS_H_
#define OMNI_CALIB_LIP_EDGE_BIAS_H_

#include <vector>

namespace omni::calib {

struct AlongEdgePattern {
  double rms_px = 0;           // the residuals across the edge, over the azimuth bins
  double correlation_deg = 0;  // integrated correlation length of the binned residuals
  double coverage_deg = 0;     // azimuth the edge's points cover
  double common_sigma_px = 0;  // rms * sqrt(correlation / coverage): the constant part's sigma
};

// The binning of the residuals along the edge (deg): the normal points are at most 0.25 deg
// wide; whole degrees average their white noise and keep patterns a few degrees long.
constexpr double kAlongEdgeBinDeg = 1.0;

// `azimuth_rad[i]`: point i's azimuth about the principal point; `across_px[i]`: its residual
// across the edge (outward). Binned by kAlongEdgeBinDeg; the autocorrelation of the bins summed
// over lags (both sides) until it first falls to zero (the solve's absorbing of the edge's low
// orders makes it negative beyond the pattern's length), lags with at least 10 pairs of bins.
// An edge with fewer than 2 bins: its rms as the common sigma.
AlongEdgePattern CommonPartOfAlongEdgePattern(const std::vector<double>& azimuth_rad,
                                              const std::vector<double>& across_px);

}  // namespace omni::calib

#endif  // OMNI_CALIB_LIP_EDGE_BIAS_H_
