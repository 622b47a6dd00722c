// A single-mirror rig's rim (RigParams::Single): the circle of radius r_sys where its conic ends,
// the mark the photos show of it (detectors/lips/rim_edge.h) and the calibration's observation
// of it (calib/lip_cost.h: path direct, mirror 1's r_outer circle).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "model/conic.h"
#include "model/rig_model.h"
#include "model/rig_params.h"

namespace omni {

// The rim circle's height in mirror 1's body frame at the rig's current conic: the sag at r_sys
// above the vertex (MakeSingleRig's lip1.z at its own conic).
inline double SingleRimZ(const RigParams& rig) {
  const Conic<double> conic{rig.mirror1_shape[kShapeC], rig.mirror1_shape[kShapeK]};
  return rig.vertex_z + conic.Sag(rig.r_sys * rig.r_sys);
}

// Whether the edge of the mirror's image is its rim. Just inside the rim the mirror shows what
// its reflected rays meet: where they head past the rim's plane (away from the camera: a sphere,
// a paraboloid behind a telecentric lens, whose outer zones look back over the rim), whatever
// holds the mirror at its rim is seen in it, and the image's edge is that holder's reflection,
// not the rim (POV-Ray renders with a 3 mm flange at the rim: 8.6-9.5 px inside the rim at
// 1280x1024); where they head to the camera's side of the plane, nothing at the rim is seen in
// the mirror and its edge is the rim. *elevation_deg: the steepest such ray over the rim's
// azimuths, from the rim's plane (+: past it). A hyperboloid seen from its far focus: ~0 deg
// (its reflected rays come from the near focus, which lies at the rim's height for the sample
// mirror); the edge lay 0.12 px from the rim there.
bool RimEdgeIsTheRim(const RigModel& model, double* elevation_deg = nullptr);

// The mirror circle of radius `radius_mm` (at the conic's sag there) as the rig's rim observation:
// lip1 = {radius, radius, its height}. Where the image's edge is not the rim, the edge is still
// the image of one such circle (the mirror point whose reflected ray grazes the holder), fixed on
// the mirror: what `check` follows (health/lip_reference.h).
RigParams WithRimCircleAt(const RigParams& rig, double radius_mm);

// The rig with its mirror reaching `radius_mm` (r_sys and the rim circle lip1 there) where that is
// beyond r_sys, else unchanged. Where the photos show the mirror out to a circle beyond the
// model's rim (a telecentric paraboloid, whose size the photos do not fix: its rim at the model's
// scale is at least there), so that every ray the photos show has an image in the model.
RigParams WithMirrorReaching(const RigParams& rig, double radius_mm);

// Each point's radial offset (px, + outside) from the image of the mirror circle of radius
// `radius_mm` (at the conic's sag there), about that image's centre; empty where the circle does
// not project all round. Points whose direction finds no part of the image are skipped.
std::vector<double> RadialOffsetsFromCircle(const RigModel& model, double radius_mm,
                                           const std::vector<Eigen::Vector2d>& points);

// The radius (mm) of the mirror circle whose image the edge points lie on (the median of their
// radial offsets from it zero, by bisection over 0.2-2 r_sys); 0 if the points are fewer than 20
// or no radius in that span brackets them.
double RimCircleRadiusOf(const RigModel& model, const std::vector<Eigen::Vector2d>& edge_points);

}  // namespace omni
