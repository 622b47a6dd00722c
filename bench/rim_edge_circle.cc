// What the edge of a single mirror's image is, against a model (the true one for renders): per
// photo, the radius of the mirror circle its detected edge points lie on (model/single_rim.h
// RimCircleRadiusOf) and their scatter about that circle's image, and about the circle of all
// photos' median radius; and how far the edge lies inside the rim. Where the edge is the image of
// one circle fixed on the mirror, the radii agree across photos and the scatter is the
// detector's noise. Not a test:
//   rim_edge_circle MODEL DETECTIONS
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "io/detections_file.h"
#include "io/model_file.h"
#include "model/single_rim.h"

namespace {

struct Scatter {
  double median = 0, rms = 0, max = 0;
  int n = 0;
};

Scatter ScatterOf(std::vector<double> offsets) {
  Scatter s;
  s.n = static_cast<int>(offsets.size());
  if (offsets.empty()) return s;
  std::nth_element(offsets.begin(), offsets.begin() + s.n / 2, offsets.end());
  s.median = offsets[s.n / 2];
  for (double o : offsets) {
    s.rms += (o - s.median) * (o - s.median);
    s.max = std::max(s.max, std::abs(o - s.median));
  }
  s.rms = std::sqrt(s.rms / s.n);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: rim_edge_circle MODEL DETECTIONS\n");
    return 2;
  }
  const omni::RigModel model(omni::io::ReadModelFile(argv[1]));
  const omni::Observations detections = omni::io::ReadDetectionsFile(argv[2]);
  std::vector<std::vector<Eigen::Vector2d>> edges;
  std::vector<double> radii;
  for (const omni::ImageObservations& image : detections.images) {
    std::vector<Eigen::Vector2d> edge;
    for (const omni::LipEdgeObservation& lip : image.lips) {
      if (lip.path == omni::LipPath::kDirect) edge.insert(edge.end(), lip.points.begin(), lip.points.end());
    }
    edges.push_back(edge);
    radii.push_back(omni::RimCircleRadiusOf(model, edge));
  }
  std::vector<double> sorted = radii;
  std::sort(sorted.begin(), sorted.end());
  const double common = sorted[sorted.size() / 2];
  const double r_sys = model.params().r_sys;
  std::printf("rim r_sys %.3f mm; median edge circle radius over %zu photos %.4f mm\n", r_sys,
              radii.size(), common);
  std::printf("photo  points  radius_mm  about_own(rms max px)  about_common(median rms px)  "
              "rim_offset(median px)\n");
  for (size_t i = 0; i < edges.size(); ++i) {
    const Scatter own = ScatterOf(omni::RadialOffsetsFromCircle(model, radii[i], edges[i]));
    const Scatter all = ScatterOf(omni::RadialOffsetsFromCircle(model, common, edges[i]));
    const Scatter rim = ScatterOf(omni::RadialOffsetsFromCircle(model, r_sys, edges[i]));
    std::printf("%5zu  %6zu  %9.4f  %8.3f %8.3f         %8.3f %8.3f             %8.2f\n", i + 1,
                edges[i].size(), radii[i], own.rms, own.max, all.median, all.rms, rim.median);
  }
  return 0;
}
