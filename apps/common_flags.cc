#include "apps/common_flags.h"

DEFINE_string(model, "", "model file (omnistereo-model/1 YAML)");
DEFINE_string(out, "", "output file or folder");
DEFINE_string(config, "", "configuration file (YAML)");
DEFINE_string(session, "", "session file (omnistereo-session/1 YAML)");
DEFINE_string(scene, "", "scene file (omnistereo-scene/1 YAML)");
DEFINE_string(detections, "", "detections file (omnistereo-detections/1 YAML)");
DEFINE_string(points, "", "CSV of 3D points in the camera frame, header x_mm,y_mm,z_mm");
DEFINE_string(pixels, "", "CSV of pixels, header u,v");
// 3D sensing (triangulate, panorama, depth).
DEFINE_string(image, "", "raw omnidirectional image (PNG, JPEG, ...) of the model's size");
DEFINE_double(sigma_px, 1.0, "pixel noise sigma for the covariance [uncertainty_propagation]");
DEFINE_int32(panorama_width, 1280, "panorama width in pixels (height from [panorama_pixel_size])");
DEFINE_double(cylinder_radius_mm, 2000.0, "radius of the panorama projection cylinder (mm)");
DEFINE_string(frame, "cam", "frame of output points, covariances and rays: cam (C) | mirror1 "
                            "(M1, mirror 1's body; triangulate --truth compares in the true rig's M1)");
