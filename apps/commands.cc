#include <cstdio>

#include "apps/command.h"

namespace omni::apps {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"design", "maximise the baseline of an ideal rig design [optimization_of_baseline]",
       {"config", "out", "curves_out"}, RunDesign,
       {{"out", "the ideal model file to write (omnistereo-model/1 YAML)"}}},
      {"render", "render a rig model and scene with POV-Ray, with ground truth",
       {"model", "scene", "out", "no_render", "jobs", "keep_pinhole"}, RunRender,
       {{"out", "the folder to write: the images, model.yaml, truth.yaml and session.yaml"}}},
      {"detect", "detect targets and lips in a session's images", {"session", "out", "overlay", "model"},
       RunDetect, {{"out", "the detections file to write (omnistereo-detections/1 YAML)"}}},
      {"calibrate", "bundle-adjust the non-central model from a session",
       {"session", "out", "detections", "truth_model", "truth", "report", "report_range_mm",
        "tolerances"},
       RunCalibrate,
       {{"out", "the calibrated model file to write (omnistereo-model/1 YAML; the detections "
                "beside it as <name>_detections.yaml when detected here)"},
        {"truth", "ground truth of a synthetic session (omnistereo-truth/1): print the "
                  "reprojection RMS per ring against the detector's true corner error"}}},
      {"report", "the HTML report of a calibrated model from its detections (as calibrate --report)",
       {"model", "detections", "out", "session", "report_range_mm", "tolerances"}, RunReport,
       {{"out", "the report's folder to write (index.html and its figures)"}}},
      {"project", "project 3D points (CSV x_mm,y_mm,z_mm) to pixels via both mirrors",
       {"model", "points", "out"}, RunProject,
       {{"out", "the CSV to write: u1,v1,valid1,u2,v2,valid2 (pixel via mirror 1 / mirror 2)"}}},
      {"unproject", "back-project pixels (CSV u,v) to rays", {"model", "pixels", "out"},
       RunUnproject, {{"out", "the CSV to write: mirror,ox,oy,oz,dx,dy,dz,valid (rays in C)"}}},
      {"triangulate", "triangulate corners seen in both rings, with covariance",
       {"model", "detections", "out", "sigma_px", "sigma_px_ring2", "truth", "noise_px", "seed",
        "method", "model_covariance", "noise_px_ring2", "seeds", "frame"},
       RunTriangulate,
       {{"out", "the CSV to write: one row per corner seen in both rings, image,target,id,x_mm,"
                "y_mm,z_mm and the covariance"},
        {"sigma_px", "each corner's pixel noise (px per axis) for the points' covariance; not "
                     "given: a calibrated model's measured corner noise per ring (its calibration "
                     "block's per-ring 2-D RMS / sqrt 2), else the default"},
        {"frame", "frame of the output points and covariances: cam (C) | mirror1 (M1, mirror 1's "
                  "body; --truth then compares in the true rig's M1)"}}},
      {"tolerance", "check a (calibrated) rig against assembly tolerances; simulate their image effect", {"model", "config"},
       RunTolerance},
      {"panorama", "unwarp both rings into panoramas",
       {"model", "image", "out", "panorama_width", "cylinder_radius_mm"}, RunPanorama,
       {{"out", "the folder to write panorama1.png and panorama2.png into"}}},
      {"depth", "dense stereo on the panoramas to a point cloud (one --image, or --images: a "
                "cloud per frame)",
       {"model", "image", "images", "out", "panorama_width", "cylinder_radius_mm", "sigma_px",
        "num_disparities", "block_size", "max_sigma_mm", "ply_ascii"},
       RunDepth,
       {{"out", "the folder to write into: with --image the panoramas, disparity.png, "
                "disparity16.png and cloud.ply; with --images one <image name>.ply per frame"}},
       /*image_apart_from_images=*/true},
      {"export", "model data for other programs: ray table (.npy), panorama maps (.npz), central "
                 "approximations (Kalibr camchain .yaml, basalt .json)",
       {"model", "format", "out", "frame", "dtype", "panorama_width", "cylinder_radius_mm",
        "allow_uncalibrated"},
       RunExport,
       {{"out", "the file to write, ending as --format writes it: .npy (rays), .npz "
                "(panorama_maps), .yaml (kalibr), .json (basalt)"}}},
      {"init", "write a session for a built rig's photos (starting model from the design and the "
               "lips, or for a single mirror from its rim)",
       {"images", "design", "targets", "posts", "post_width", "mirror_diameter", "mirror", "lens",
        "camera_distance", "focal_px", "magnification", "unified", "out"}, RunInit,
       {{"out", "the session file to write (omnistereo-session/1 YAML; the starting model beside "
                "it as start_model.yaml)"}}},
      {"target", "a printable target at exact size (PDF, SVG, PNG) and its session entry",
       {"type", "rows", "cols", "size", "spacing", "first_id", "out", "paper", "dpi"}, RunTarget,
       {{"out", "the sheet to write: a .pdf, .svg or .png path"}}},
      {"check", "does the stored calibration still hold? natural-scene photos, no target "
                "(exit 0 OK, 3 DRIFTED, 4 CANNOT TELL)",
       {"model", "image", "images", "tone", "bayer", "out"}, RunCheck,
       {{"out", "optional: the verdict file to write (omnistereo-check/1 YAML)"}}},
      {"refine", "re-estimate what moved since the calibration from natural-scene photos, with "
                 "covariance",
       {"model", "image", "images", "tone", "bayer", "estimate", "out", "truth_model"}, RunRefine,
       {{"out", "the refined model file to write (omnistereo-model/1 YAML)"}}},
      {"demo", "run the main job on the bundled default", {"out"}, RunDemo,
       {{"out", "the folder to write the renders, detections, calibrated model and report into "
                "(empty: demo_out)"}}},
  };
  return commands;
}

int NotYetImplemented(const char* name, const char* issue) {
  std::fprintf(stderr, "omnistereo %s: not implemented yet (%s)\n", name, issue);
  return 2;
}

}  // namespace omni::apps
