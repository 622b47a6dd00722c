// The residual samples of a session's evidence under a model, and their bins (what check.h's
// statistic and refine.h's solve are built on): every ring-to-ring match's ray gap and a spread
// subsample of each lip edge's points (consistency.h), binned by azimuth (matches: also by the
// upper / lower half of their elevations; lips: per edge), with a robust mean per bin (3-sigma
// clipped about its median) and a standard error from the scatter pooled over the bin's kind,
// widened by the kind's floor (CheckOptions). A lip bin the calibration photos saw
// (lip_reference.h) is measured from their mean instead, its error from their scatter.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "health/check.h"
#include "health/consistency.h"
#include "health/lip_reference.h"
#include "model/rig_model.h"

namespace omni::health {

// One residual sample: a match's ray gap or a lip point's distance across its edge.
struct Sample {
  bool is_match = true;
  Eigen::Vector2d pixel1 = Eigen::Vector2d::Zero(), pixel2 = Eigen::Vector2d::Zero();  // match
  double w = 0;          // match: the converged inverse range of its point on ray 1
  LipPointResidual lip;  // lip point: its edge, pixel, and (once valid) phi and normal
  int image = 0;         // index of its photo
  double reference = 0;  // lip: the calibration photos' mean in its bin (0 without one)
  double value = 0;      // px, under the model the set was collected with, less `reference`
  bool valid = false;    // the model images it
  bool kept = false;     // inside its bin's clipping, in a bin that is used
  int bin = 0;           // key of its bin
};

struct SampleBin {
  std::string kind;  // "matches" or the lip edge ("via_mirror2 r_outer")
  double azimuth_deg = 0;  // of the bin's centre
  std::vector<int> members;  // kept samples
  double mean = 0, standard_error = 0;  // px; the error includes the kind's floor
  std::optional<LipReferenceBin> reference;  // the calibration photos' bin it is measured from
  int photos = 0;  // photos among its members
};

struct SampleSet {
  std::vector<Sample> samples;
  std::vector<SampleBin> bins;  // those with at least min_bin_count kept samples
  std::map<std::string, double> kind_sd;  // the pooled scatter per kind about the bin means (px)
  int n_matches = 0, n_lip_points = 0;  // valid samples
};

SampleSet CollectSamples(const RigModel& model, const std::vector<ImageEvidence>& images,
                         const CheckOptions& options, const LipReference& reference = {});

// A single mirror's evidence is its rim's edge, whose offset from the model's rim the calibration
// photos measured (lip_reference.h): the edge the photos show need not be the rim itself (a
// holder seen in the mirror's outer zone, model/single_rim.h RimEdgeIsTheRim), so only the bins
// they measured can tell a move. The set with the others' samples left out (kept false).
SampleSet ReferencedBinsOnly(const SampleSet& set);

// The check (check.h CheckRig) on samples already collected under `stored`.
CheckResult CheckSamples(const RigParams& stored, const SampleSet& set, int n_images,
                         const CheckOptions& options);

// A sample's residual under another model: a match's exact ray gap (started from its w), a lip
// point's distance at its phi and normal (first order: LipResidualUnder), less its reference.
std::optional<double> ResidualUnder(const RigModel& model, const Sample& sample);

// The bin of an azimuth (rad) among `bins` equal sectors.
int AzimuthBin(double angle, int bins);

}  // namespace omni::health
