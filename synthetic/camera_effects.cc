#include "synthetic/camera_effects.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model/rig_frames.h"
#include "synthetic/image_effects.h"

namespace omni::synthetic {

bool CameraEffects::IsClean() const {
  return defocus_sigma_px[0] <= 0 && defocus_sigma_px[1] <= 0 && vignetting <= 0 &&
         exposure == 1 && bayer == io::BayerPattern::kNone && full_well_e <= 0 &&
         read_noise <= 0 && tone == ToneCurve::kLinear && bits == 8 && jpeg_quality == 0 &&
         !raw_mosaic;
}

std::string CameraEffects::Summary() const {
  char buf[400];
  std::snprintf(buf, sizeof(buf),
                "%s: defocus %.2f/%.2f px, vignetting %.2f, exposure %.2f, %s%s%s, full well %.0f "
                "e-, read noise %.2f, %s, %d bit, %s",
                preset.c_str(), defocus_sigma_px[0], defocus_sigma_px[1], vignetting, exposure,
                bayer == io::BayerPattern::kNone ? "no mosaic" : io::BayerName(bayer).c_str(),
                bayer == io::BayerPattern::kNone ? "" : " ",
                bayer == io::BayerPattern::kNone
                    ? ""
                    : (raw_mosaic ? "raw" : io::DemosaicName(demosaic).c_str()),
                full_well_e, read_noise, tone == ToneCurve::kSrgb ? "sRGB" : "linear", bits,
                jpeg_quality > 0 ? ("JPEG " + std::to_string(jpeg_quality)).c_str() : "PNG");
  return buf;
}

std::string CameraEffects::Check() const {
  if (defocus_sigma_px[0] < 0 || defocus_sigma_px[1] < 0) return "defocus_sigma_px: expected >= 0";
  if (vignetting < 0 || vignetting > 0.9) return "vignetting: expected 0..0.9";
  if (!(exposure > 0)) return "exposure: expected > 0";
  if (full_well_e < 0) return "full_well_e: expected >= 0";
  if (read_noise < 0) return "read_noise: expected >= 0";
  if (bits != 8 && bits != 16) return "bits: expected 8 or 16";
  if (jpeg_quality < 0 || jpeg_quality > 100) return "jpeg_quality: expected 0 (PNG) or 1..100";
  if (jpeg_quality > 0 && bits != 8) return "jpeg_quality: JPEG holds 8 bit only, expected bits: 8";
  if (raw_mosaic && bayer == io::BayerPattern::kNone) return "raw_mosaic: expected a bayer pattern";
  if (raw_mosaic && jpeg_quality > 0) return "raw_mosaic: a raw frame is written as PNG, expected jpeg_quality: 0";
  return "";
}

std::optional<CameraEffects> CameraPreset(const std::string& name) {
  CameraEffects e;
  e.preset = name;
  if (name == "clean") return e;
  if (name == "mild") {
    e.defocus_sigma_px[0] = 0.3;
    e.defocus_sigma_px[1] = 0.5;
    e.vignetting = 0.1;
    e.bayer = io::BayerPattern::kRGGB;
    e.demosaic = io::Demosaic::kEdgeAware;
    e.full_well_e = 20000;
    e.read_noise = 0.5;
    e.tone = ToneCurve::kSrgb;
    return e;
  }
  if (name == "realistic") {
    e.defocus_sigma_px[0] = 0.6;
    e.defocus_sigma_px[1] = 0.9;
    e.vignetting = 0.25;
    e.bayer = io::BayerPattern::kRGGB;
    e.demosaic = io::Demosaic::kEdgeAware;
    e.full_well_e = 10000;
    e.read_noise = 1.0;
    e.tone = ToneCurve::kSrgb;
    e.jpeg_quality = 92;
    return e;
  }
  if (name == "harsh") {
    e.defocus_sigma_px[0] = 0.9;
    e.defocus_sigma_px[1] = 1.3;
    e.vignetting = 0.45;
    e.exposure = 0.6;
    e.bayer = io::BayerPattern::kGRBG;
    e.demosaic = io::Demosaic::kBilinear;
    e.full_well_e = 4000;
    e.read_noise = 2.5;
    e.tone = ToneCurve::kSrgb;
    e.jpeg_quality = 75;
    return e;
  }
  if (name == "webcam") {
    // The paper's prototype camera (a 5-megapixel USB webcam, 2592x1944, MJPEG): the
    // harsh chain's blur scaled by the pixel size (2.025x the pixels of 1280x960 across), small
    // pixels' noise, its JPEG at quality 80. The image size is the scene's (image:).
    e.defocus_sigma_px[0] = 1.8;
    e.defocus_sigma_px[1] = 2.6;
    e.vignetting = 0.35;
    e.bayer = io::BayerPattern::kGRBG;
    e.demosaic = io::Demosaic::kBilinear;
    e.full_well_e = 5000;
    e.read_noise = 2.0;
    e.tone = ToneCurve::kSrgb;
    e.jpeg_quality = 80;
    return e;
  }
  return std::nullopt;
}

std::vector<std::string> CameraPresetNames() {
  return {"clean", "mild", "realistic", "harsh", "webcam"};
}

cv::Mat InnerRingWeight(const RigParams& rig, double feather_px) {
  // The reflex disc's rim in C: mirror 1's pose applied to the disc of radius r_ref about the
  // reflex plane's point (rig_frames.h), imaged straight through the lens (the camera sees the
  // disc directly; everything inside its image is the inner ring).
  if (rig.Single()) return cv::Mat(rig.image_height, rig.image_width, CV_32F, cv::Scalar(0));
  const Pose<double> cam_from_mirror1 = PoseFromBlock(rig.mirror1_pose.data());
  const Pinhole<double> cam = rig.Intrinsics();
  const RadTan<double> dist = rig.Distortion();
  std::vector<cv::Point> rim;
  constexpr int kSamples = 720;
  constexpr int kSub = 16;  // fixed-point sub-pixel bits of fillPoly: 1/16 px
  for (int k = 0; k < kSamples; ++k) {
    const double phi = 2 * M_PI * k / kSamples;
    const Eigen::Vector3d p =
        cam_from_mirror1 * ReflexRimInMirror1(rig.reflex.data(), rig.d, rig.r_ref, phi);
    const Eigen::Vector2d uv = cam.PixelFromNormalized(dist.Distort(Eigen::Vector2d(p.x() / p.z(), p.y() / p.z())));
    rim.emplace_back(cvRound(uv.x() * kSub), cvRound(uv.y() * kSub));
  }
  cv::Mat mask(rig.image_height, rig.image_width, CV_32F, cv::Scalar(0));
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{rim}, cv::Scalar(1), cv::LINE_AA, 4);
  if (feather_px > 0) cv::GaussianBlur(mask, mask, cv::Size(0, 0), feather_px);
  return mask;
}

namespace {

cv::Mat Defocus(const cv::Mat& image, const RigParams& rig, const double sigma[2]) {
  auto blur = [&](double s) {
    if (s <= 0) return image.clone();
    cv::Mat out;
    cv::GaussianBlur(image, out, cv::Size(0, 0), s, s, cv::BORDER_REFLECT);
    return out;
  };
  const cv::Mat outer = blur(sigma[0]);
  if (sigma[1] == sigma[0] || rig.Single()) return outer;  // a single rig: its one ring
  const cv::Mat inner = blur(sigma[1]);
  const cv::Mat w = InnerRingWeight(rig);
  cv::Mat out(image.size(), image.type());
  const int ch = image.channels();
  for (int v = 0; v < image.rows; ++v) {
    const float* o = outer.ptr<float>(v);
    const float* i = inner.ptr<float>(v);
    const float* wv = w.ptr<float>(v);
    float* dst = out.ptr<float>(v);
    for (int u = 0; u < image.cols; ++u) {
      for (int c = 0; c < ch; ++c) dst[u * ch + c] = o[u * ch + c] + wv[u] * (i[u * ch + c] - o[u * ch + c]);
    }
  }
  return out;
}

void Vignette(cv::Mat* image, const RigParams& rig, double v) {
  if (v <= 0) return;
  const double cx = rig.camera[kCx], cy = rig.camera[kCy];
  const double corner2 = std::max({cx * cx + cy * cy,
                                   std::pow(rig.image_width - 1 - cx, 2) + cy * cy,
                                   cx * cx + std::pow(rig.image_height - 1 - cy, 2),
                                   std::pow(rig.image_width - 1 - cx, 2) +
                                       std::pow(rig.image_height - 1 - cy, 2)});
  const int ch = image->channels();
  for (int y = 0; y < image->rows; ++y) {
    float* p = image->ptr<float>(y);
    for (int x = 0; x < image->cols; ++x) {
      const float g = static_cast<float>(1 - v * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / corner2);
      for (int c = 0; c < ch; ++c) p[x * ch + c] *= g;
    }
  }
}

// Shot noise (Gaussian with the Poisson variance of the electron count) and read noise on a
// linear image in [0, 1], then clipped to the sensor's range.
void SensorNoise(cv::Mat* linear, const CameraEffects& e, unsigned seed) {
  cv::RNG rng(seed);
  const double read_sigma = e.read_noise / 255.0;
  const int n = linear->rows * linear->cols * linear->channels();
  float* p = linear->ptr<float>(0);
  CV_Assert(linear->isContinuous());
  for (int k = 0; k < n; ++k) {
    double x = std::clamp(static_cast<double>(p[k]), 0.0, 1.0);
    double var = read_sigma * read_sigma;
    if (e.full_well_e > 0) var += x / e.full_well_e;
    if (var > 0) x += std::sqrt(var) * rng.gaussian(1.0);
    p[k] = static_cast<float>(std::clamp(x, 0.0, 1.0));
  }
}

cv::Mat Quantise(const cv::Mat& unit, int bits) {
  cv::Mat out;
  unit.convertTo(out, bits == 16 ? CV_16U : CV_8U, bits == 16 ? 65535.0 : 255.0);
  return out;
}

}  // namespace

cv::Mat ApplyCamera(const cv::Mat& linear_render, const RigParams& rig,
                    const CameraEffects& e, unsigned seed) {
  CV_Assert(linear_render.channels() == 3);
  cv::Mat f;
  linear_render.convertTo(f, CV_32FC3, linear_render.depth() == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0);
  f = ApplyDistortion(f, rig);
  if (e.defocus_sigma_px[0] > 0 || e.defocus_sigma_px[1] > 0) f = Defocus(f, rig, e.defocus_sigma_px);
  Vignette(&f, rig, e.vignetting);
  if (e.exposure != 1) f *= e.exposure;

  cv::Mat signal = f;  // what the sensor's pixels collect: 3 channels, or the mosaic
  if (e.bayer != io::BayerPattern::kNone) {
    signal = cv::Mat(f.size(), CV_32F);
    for (int y = 0; y < f.rows; ++y) {
      const cv::Vec3f* src = f.ptr<cv::Vec3f>(y);
      float* dst = signal.ptr<float>(y);
      for (int x = 0; x < f.cols; ++x) dst[x] = src[x][io::BayerChannel(e.bayer, y, x)];
    }
  }
  if (e.full_well_e > 0 || e.read_noise > 0) SensorNoise(&signal, e, seed);
  else cv::min(cv::max(signal, 0.0), 1.0, signal);
  if (e.raw_mosaic) return Quantise(signal, e.bits);

  cv::Mat colour = signal;
  if (e.bayer != io::BayerPattern::kNone) {
    // The camera's processor demosaics its ADC's output (here 16 bit, linear).
    cv::Mat demosaiced = io::DemosaicImage(Quantise(signal, 16), e.bayer, e.demosaic);
    demosaiced.convertTo(colour, CV_32FC3,
                         demosaiced.depth() == CV_16U ? 1.0 / 65535.0 : 1.0 / 255.0);
  }
  if (e.tone == ToneCurve::kSrgb) {
    float* p = colour.ptr<float>(0);
    CV_Assert(colour.isContinuous());
    const int n = colour.rows * colour.cols * colour.channels();
    for (int k = 0; k < n; ++k) p[k] = static_cast<float>(io::SrgbFromLinear(p[k]));
  }
  return Quantise(colour, e.bits);
}

std::string ImageExtension(const CameraEffects& effects) {
  return effects.jpeg_quality > 0 ? ".jpg" : ".png";
}

bool EncodeCameraImage(const cv::Mat& image, const CameraEffects& effects,
                       std::vector<uchar>* bytes) {
  if (effects.jpeg_quality > 0) {
    return cv::imencode(".jpg", image, *bytes, {cv::IMWRITE_JPEG_QUALITY, effects.jpeg_quality});
  }
  return cv::imencode(".png", image, *bytes);
}

}  // namespace omni::synthetic
