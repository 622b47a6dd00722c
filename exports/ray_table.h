// The ray table export: for every pixel of the image and each ring, the back-projected
// ray of the calibrated (non-central) model, so that other programs can triangulate without our
// library.
//
// Array shape (2, H, W, 6): [ring][v][u][ox, oy, oz, dx, dy, dz]; ring 0 is mirror 1's (the
// outer ring), ring 1 mirror 2's (the inner ring); a single-mirror rig's (1, H, W, 6) its ring's; (u, v) pixel centres at integer coordinates
// (OpenCV's convention, docs/design.md, Conventions); origin in mm on the mirror (the reflection point), direction
// a unit vector towards the scene; NaN in all six where the pixel does not see that ring.
// Frame: the camera frame C, or mirror 1's body M1 (ReferenceBody::kMirror1: the rig's physical
// frame, where a calibration is most certain).
#pragma once

#include "exports/npy.h"
#include "model/rig_model.h"
#include "model/triangulation.h"

namespace omni::exports {

// The table for `model`, computed in parallel over rows. Float32 (the default of the export)
// holds origins to ~1e-5 mm and directions to ~6e-8 rad, i.e. 0.1 um at 2 m; float64 the
// model's own precision.
NpyArray RayTable(const RigModel& model, ReferenceBody frame, DType dtype);

}  // namespace omni::exports
