#include "exports/camchain.h"

#include <cstdio>

#include <Eigen/Geometry>

#include "io/file_util.h"

namespace omni::exports {
namespace {

std::string Num(double v) { return io::FormatDouble(v); }

// `text` as the inside of a JSON string.
std::string JsonEscaped(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

const char* FrameName(ReferenceBody frame) {
  return frame == ReferenceBody::kMirror1 ? "M1 (mirror 1's body)" : "C (the camera frame)";
}

std::string Matrix4(const Pose<double>& pose, const std::string& indent) {
  std::string out;
  for (int r = 0; r < 4; ++r) {
    out += indent + "- [";
    for (int c = 0; c < 4; ++c) {
      const double v = r == 3 ? (c == 3 ? 1.0 : 0.0)
                              : (c < 3 ? pose.rotation(r, c) : pose.translation[r] / 1000.0);
      out += Num(v) + (c < 3 ? ", " : "]\n");
    }
  }
  return out;
}

std::string ResidualComments(const CentralRing& ring, const std::string& prefix) {
  std::string out;
  for (const CentralResidual& r : ring.residuals) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "%sat %.2f m along the rays: RMS %.3f px, max %.3f px over %d pixels%s\n",
                  prefix.c_str(), r.distance_mm / 1000, r.rms_px, r.max_px, r.pixels,
                  r.not_projected ? (" (" + std::to_string(r.not_projected) +
                                     " not projectable)").c_str()
                                  : "");
    out += buf;
  }
  return out;
}

}  // namespace

std::string KalibrCamchainYaml(const std::vector<CentralRing>& rings, int width, int height,
                               const std::string& source, ReferenceBody frame) {
  const std::string rig_frame =
      "the rig frame " + std::string(FrameName(frame)) + ", which takes the IMU's place; metres.\n";
  std::string out =
      rings.size() == 1
          ? "# Kalibr camchain: the central approximation (unified model, omni + radtan) of the\n"
            "# calibrated non-central single-mirror camera " + source + ",\n"
            "# written by `omnistereo export --format kalibr`. cam0: its mirror's ring.\n"
            "# T_cam_imu: the camera from " + rig_frame
          : "# Kalibr camchain: central approximations (unified model, omni + radtan) of the two rings\n"
            "# of the calibrated non-central omnistereo rig " + source + ",\n"
            "# written by `omnistereo export --format kalibr`. cam0: ring 1 (mirror 1, outer ring);\n"
            "# cam1: ring 2 (mirror 2, inner ring). Both read the SAME image. T_cam_imu: the camera from\n"
            "# " + rig_frame;
  out += "# A negative fv: the ring is mirror-reversed (flip the image rows to make it positive).\n";
  for (size_t k = 0; k < rings.size(); ++k) {
    const CentralRing& ring = rings[k];
    const std::vector<double>& q = ring.intrinsics;
    out += "cam" + std::to_string(k) + ":\n";
    out += "  # what the approximation costs (pixel distance to the non-central model):\n";
    out += ResidualComments(ring, "  #   ");
    out += "  camera_model: omni\n";
    out += "  intrinsics: [" + Num(q[0]) + ", " + Num(q[1]) + ", " + Num(q[2]) + ", " + Num(q[3]) +
           ", " + Num(q[4]) + "]\n";
    out += "  distortion_model: radtan\n";
    out += "  distortion_coeffs: [" + Num(q[5]) + ", " + Num(q[6]) + ", " + Num(q[7]) + ", " +
           Num(q[8]) + "]\n";
    out += "  resolution: [" + std::to_string(width) + ", " + std::to_string(height) + "]\n";
    out += "  rostopic: /omnistereo/image_raw\n";
    out += "  T_cam_imu:\n" + Matrix4(ring.cam_from_rig, "  ");
    if (k == 1) {
      const Pose<double> cam1_from_cam0 = {
          ring.cam_from_rig.rotation * rings[0].cam_from_rig.rotation.transpose(),
          ring.cam_from_rig.translation - ring.cam_from_rig.rotation *
                                              rings[0].cam_from_rig.rotation.transpose() *
                                              rings[0].cam_from_rig.translation};
      out += "  T_cn_cnm1:\n" + Matrix4(cam1_from_cam0, "  ");
    }
  }
  return out;
}

std::string BasaltCalibrationJson(const std::vector<CentralRing>& rings, int width, int height,
                                  const std::string& source, ReferenceBody frame) {
  std::string poses, intrinsics, resolution, residuals;
  for (size_t k = 0; k < rings.size(); ++k) {
    const CentralRing& ring = rings[k];
    const Pose<double> rig_from_cam = ring.cam_from_rig.Inverse();
    const Eigen::Quaterniond q(rig_from_cam.rotation);
    const std::string sep = k ? ",\n" : "";
    poses += sep + "      {\"px\": " + Num(rig_from_cam.translation.x() / 1000) +
             ", \"py\": " + Num(rig_from_cam.translation.y() / 1000) +
             ", \"pz\": " + Num(rig_from_cam.translation.z() / 1000) + ", \"qx\": " + Num(q.x()) +
             ", \"qy\": " + Num(q.y()) + ", \"qz\": " + Num(q.z()) + ", \"qw\": " + Num(q.w()) +
             "}";
    const std::vector<double>& p = ring.intrinsics;
    intrinsics += sep + "      {\"camera_type\": \"ds\", \"intrinsics\": {\"fx\": " + Num(p[0]) +
                  ", \"fy\": " + Num(p[1]) + ", \"cx\": " + Num(p[2]) + ", \"cy\": " + Num(p[3]) +
                  ", \"xi\": " + Num(p[4]) + ", \"alpha\": " + Num(p[5]) + "}}";
    resolution += sep + "      [" + std::to_string(width) + ", " + std::to_string(height) + "]";
    std::string list;
    for (size_t i = 0; i < ring.residuals.size(); ++i) {
      const CentralResidual& r = ring.residuals[i];
      list += std::string(i ? ", " : "") + "{\"distance_m\": " + Num(r.distance_mm / 1000) +
              ", \"rms_px\": " + Num(r.rms_px) + ", \"max_px\": " + Num(r.max_px) +
              ", \"pixels\": " + std::to_string(r.pixels) + "}";
    }
    residuals += sep + "        [" + list + "]";
  }
  const std::string frame_text = FrameName(frame);
  const std::string note =
      rings.size() == 1
          ? "the central approximation (double sphere) of the calibrated non-central "
            "single-mirror camera " + JsonEscaped(source) + "; camera 0: its mirror's ring"
          : "central approximations (double sphere) of the two rings of the calibrated "
            "non-central rig " + JsonEscaped(source) + "; camera 0: ring 1 (mirror 1, outer), "
            "camera 1: ring 2 (mirror 2, inner), both on the same image";
  return "{\n  \"value0\": {\n    \"T_imu_cam\": [\n" + poses + "\n    ],\n" +
         "    \"intrinsics\": [\n" + intrinsics + "\n    ],\n" +
         "    \"resolution\": [\n" + resolution + "\n    ],\n" +
         "    \"vignette\": [],\n"
         "    \"calib_accel_bias\": [0, 0, 0, 0, 0, 0, 0, 0, 0],\n"
         "    \"calib_gyro_bias\": [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],\n"
         "    \"imu_update_rate\": 200.0,\n"
         // basalt's Calibration holds these as 3-vectors (a number is refused), and zeros would
         // give an IMU infinite weight: basalt_calibrate_imu's defaults (EuRoC's IMU).
         "    \"accel_noise_std\": [0.016, 0.016, 0.016],\n"
         "    \"gyro_noise_std\": [0.000282, 0.000282, 0.000282],\n"
         "    \"accel_bias_std\": [0.001, 0.001, 0.001],\n"
         "    \"gyro_bias_std\": [0.0001, 0.0001, 0.0001],\n"
         "    \"cam_time_offset_ns\": 0\n"
         "  },\n"
         "  \"omnistereo\": {\n"
         "    \"note\": \"" + note + "; the 'imu' frame is the rig frame " +
         frame_text + "; a negative fy: the ring is mirror-reversed\",\n"
         "    \"residuals\": [\n" + residuals + "\n    ]\n"
         "  }\n}\n";
}

}  // namespace omni::exports
