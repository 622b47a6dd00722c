#include <cstdio>

#include "apps/command.h"

namespace omni::apps {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"design", "maximise the baseline of an ideal rig design [optimization_of_baseline]",
       {"config", "out", "curves_out"}, RunDesign},
      {"render", "render a rig model and scene with POV-Ray, with ground truth",
       {"model", "scene", "out", "no_render", "jobs", "keep_pinhole"}, RunRender},
      {"detect", "detect targets and lips in a session's images", {"session", "out", "overlay", "model"},
       RunDetect},
      {"calibrate", "bundle-adjust the non-central model from a session",
       {"session", "out", "detections", "truth_model", "truth", "report", "report_range_mm",
        "tolerances"},
       RunCalibrate},
      {"report", "the HTML report of a calibrated model from its detections (as calibrate --report)",
       {"model", "detections", "out", "session", "report_range_mm", "tolerances"}, RunReport},
      {"project", "project 3D points (CSV x_mm,y_mm,z_mm) to pixels via both mirrors",
       {"model", "points", "out"}, RunProject},
      {"unproject", "back-project pixels (CSV u,v) to rays", {"model", "pixels", "out"},
       RunUnproject},
      {"triangulate", "triangulate corners seen in both rings, with covariance",
       {"model", "detections", "out", "sigma_px", "sigma_px_ring2", "truth", "noise_px", "seed",
        "method", "model_covariance", "noise_px_ring2", "seeds", "frame"},
       RunTriangulate},
      {"tolerance", "check a (calibrated) rig against assembly tolerances; simulate their image effect", {"model", "config"},
       RunTolerance},
      {"panorama", "unwarp both rings into panoramas",
       {"model", "image", "out", "panorama_width", "cylinder_radius_mm"}, RunPanorama},
      {"depth", "dense stereo on the panoramas to a point cloud (one --image, or --images: a "
                "cloud per frame)",
       {"model", "image", "images", "out", "panorama_width", "cylinder_radius_mm", "sigma_px",
        "num_disparities", "block_size", "max_sigma_mm", "ply_ascii"},
       RunDepth, /*image_apart_from_images=*/true},
      {"export", "model data for other programs: ray table (.npy), panorama maps (.npz), central "
                 "approximations (Kalibr camchain .yaml, basalt .json)",
       {"model", "format", "out", "frame", "dtype", "panorama_width", "cylinder_radius_mm",
        "allow_uncalibrated"},
       RunExport},
      {"init", "write a session for a built rig's photos (starting model from the design and the lips)",
       {"images", "design", "targets", "posts", "post_width", "out"}, RunInit},
      {"target", "a printable target at exact size (PDF, SVG, PNG) and its session entry",
       {"type", "rows", "cols", "size", "spacing", "first_id", "out", "paper", "dpi"}, RunTarget},
      {"check", "does the stored calibration still hold? natural-scene photos, no target "
                "(exit 0 OK, 3 DRIFTED, 4 CANNOT TELL)",
       {"model", "image", "images", "tone", "bayer", "out"}, RunCheck},
      {"refine", "re-estimate what moved since the calibration from natural-scene photos, with "
                 "covariance",
       {"model", "image", "images", "tone", "bayer", "estimate", "out", "truth_model"}, RunRefine},
      {"demo", "run the main job on the bundled default", {"out"}, RunDemo},
  };
  return commands;
}

int NotYetImplemented(const char* name, const char* issue) {
  std::fprintf(stderr, "omnistereo %s: not implemented yet (%s)\n", name, issue);
  return 2;
}

}  // namespace omni::apps
