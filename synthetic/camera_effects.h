// What a real colour camera does to the light that POV-Ray's linear pinhole render records,
// applied in the physical order:
//   1. lens distortion: the model's radtan, resampled without bias (image_effects.h);
//   2. defocus per ring: a Gaussian PSF of its own sigma in the outer ring (mirror 1) and the
//      inner ring (mirror 2 via the reflex disc); the lens focuses at one depth and the mirrors'
//      virtual images lie at different depths;
//   3. vignetting: relative illumination 1 - v (r / r_corner)^2 about the principal point;
//   4. exposure (a linear gain) and the Bayer colour filter: each pixel keeps one channel;
//   5. sensor noise on that linear signal: shot noise (Poisson, as Gaussian, from the full-well
//      electron count) and read noise;
//   6. demosaicing (OpenCV bilinear, edge-aware or VNG), as the camera's processor does;
//   7. tone curve (sRGB or linear) and quantisation to 8 or 16 bit;
//   8. JPEG compression when the image is written (ImageExtension / EncodeCameraImage).
// `raw_mosaic` stops after 5 and writes the linear mosaic itself (a raw frame).
// The ground truth is untouched by all of this: pixels stay where the (distorted) model puts them.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "io/image_file.h"
#include "model/rig_params.h"

namespace omni::synthetic {

using io::ToneCurve;

struct CameraEffects {
  std::string preset = "clean";      // the preset these values started from
  double defocus_sigma_px[2] = {0, 0};  // [0] outer ring (mirror 1), [1] inner ring (mirror 2)
  double vignetting = 0;             // illumination lost at the image corner (0..0.9)
  double exposure = 1;               // linear gain on the render's values
  io::BayerPattern bayer = io::BayerPattern::kNone;
  io::Demosaic demosaic = io::Demosaic::kEdgeAware;
  double full_well_e = 0;            // electrons at full scale (shot noise); 0: none
  double read_noise = 0;             // read noise sigma in 8-bit linear levels (0..255 scale)
  ToneCurve tone = ToneCurve::kLinear;
  int bits = 8;                      // 8 or 16 per channel
  int jpeg_quality = 0;              // 1..100: written as JPEG; 0: PNG
  bool raw_mosaic = false;           // write the Bayer mosaic (one channel, linear), not colour

  // True when nothing but the lens distortion is applied (the renders as before this module).
  bool IsClean() const;
  // One line for logs: "realistic: defocus 0.6/0.9 px, vignetting 0.25, RGGB edge_aware, ...".
  std::string Summary() const;
  // Empty if the values are consistent, else what is wrong (names the key).
  std::string Check() const;
  // How this camera's files encode light: linear for a raw mosaic, else `tone`.
  ToneCurve FileTone() const { return raw_mosaic ? ToneCurve::kLinear : tone; }
};

// "clean" (distortion only), "mild", "realistic" (the chain a machine-vision or phone camera
// delivers: defocus 0.6 / 0.9 px, vignetting 0.25, RGGB + edge-aware demosaic, 10k e- full well,
// read noise 1.0 levels, sRGB, 8 bit, JPEG 92), "harsh" (more blur and noise, under-exposed,
// bilinear demosaic, JPEG 75) and "webcam" (the paper's 5-megapixel webcam at 2592x1944: the harsh
// blur scaled with the pixel size, 1.8 / 2.6 px, JPEG 80). nullopt for an unknown name.
std::optional<CameraEffects> CameraPreset(const std::string& name);
std::vector<std::string> CameraPresetNames();

// Weight of the inner ring (mirror 2, inside the reflex disc's image) at every pixel, 0..1,
// feathered over `feather_px` across the disc's rim: the image of the reflex disc's rim circle
// through the rig's camera (intrinsics and distortion). A single-mirror rig has no inner ring:
// zero everywhere.
cv::Mat InnerRingWeight(const RigParams& rig, double feather_px = 1.5);

// The camera applied to a linear render at the rig's image size (BGR, 8 or 16 bit, before lens
// distortion). Returns BGR (or the one-channel mosaic with raw_mosaic) at effects.bits.
cv::Mat ApplyCamera(const cv::Mat& linear_render, const RigParams& rig,
                    const CameraEffects& effects, unsigned seed);

// ".jpg" when the effects write JPEG, else ".png".
std::string ImageExtension(const CameraEffects& effects);
// The encoded file (PNG, or JPEG at effects.jpeg_quality); false if OpenCV cannot encode it.
bool EncodeCameraImage(const cv::Mat& image, const CameraEffects& effects,
                       std::vector<uchar>* bytes);

}  // namespace omni::synthetic
