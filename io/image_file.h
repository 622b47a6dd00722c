// Images as cameras write them: 8- or 16-bit PNG, TIFF or JPEG, grey or colour, or a raw Bayer
// frame (one channel, the sensor's mosaic) that we demosaic ourselves. The Bayer pattern names
// the colours of the top-left 2x2 block, row by row (RGGB: R at (0,0), G at (0,1) and (1,0), B at
// (1,1)); OpenCV names the same patterns by their second row (RGGB is its "BayerBG").
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "io/file_util.h"

namespace omni::io {

// A missing or undecodable image file (as opposed to one that decodes to an unusable layout).
class UnreadableImage : public InputError {
 public:
  using InputError::InputError;
};

enum class BayerPattern { kNone, kRGGB, kBGGR, kGRBG, kGBRG };
enum class Demosaic { kBilinear, kEdgeAware, kVng };
// How pixel values encode light: sRGB's curve (what colour cameras and JPEGs deliver) or linear
// (raw frames, machine-vision cameras with gamma off, our clean renders).
enum class ToneCurve { kLinear, kSrgb };

// "RGGB", "BGGR", "GRBG", "GBRG" (any case); "none" or "" -> kNone; nullopt for anything else.
std::optional<BayerPattern> ParseBayerPattern(const std::string& name);
std::string BayerName(BayerPattern pattern);
// "bilinear", "edge_aware", "vng"; nullopt for anything else.
std::optional<Demosaic> ParseDemosaic(const std::string& name);
std::string DemosaicName(Demosaic demosaic);

// "srgb" or "linear"; nullopt for anything else.
std::optional<ToneCurve> ParseToneCurve(const std::string& name);
std::string ToneCurveName(ToneCurve tone);

// sRGB's encoding of linear light, both in [0, 1] (IEC 61966-2-1; clamped).
double SrgbFromLinear(double linear);

// A 16-bit image of the same channels whose values are linear in the light (an 8- or 16-bit
// input decoded through `tone`). Detectors measure edges as the halfway level between two
// surfaces, which only a linear image puts where the edge is.
cv::Mat LinearImage(const cv::Mat& image, ToneCurve tone);

// The BGR channel index (0 blue, 1 green, 2 red) the sensor samples at (row, col).
int BayerChannel(BayerPattern pattern, int row, int col);

// A one-channel 8- or 16-bit mosaic demosaiced to BGR of the same depth (OpenCV's VNG takes
// 8 bit only: a 16-bit mosaic is scaled to 8 bit first and the result is 8 bit).
cv::Mat DemosaicImage(const cv::Mat& mosaic, BayerPattern pattern, Demosaic demosaic);

// True for a JPEG file whose colour components (Cb, Cr) are stored at a lower resolution than its
// luma (4:2:0, 4:2:2, 4:1:1: what cameras and most software write), read from its frame header;
// false for 4:4:4, grey JPEGs and every other file. Detectors that place edges on colour need
// it: the chroma of such a file is blurred twice as much as its luma, in sRGB.
bool HasHalvedChroma(const std::string& path);
// The same for a file's bytes (its start: the headers before the first scan).
bool HasHalvedChroma(const std::vector<unsigned char>& bytes);
// Such a file's own luma plane Y' (8-bit, decoded without colour conversion: libjpeg hands out its
// Y component), the values a colour decode clips where the halved chroma overshoots; empty for
// any other file.
cv::Mat ReadStoredLuma(const std::string& path);
cv::Mat ReadStoredLuma(const std::vector<unsigned char>& bytes);

// Reads an image for detection. Accepted: 8- or 16-bit grey, BGR or BGRA (PNG, TIFF, JPEG, ...);
// with `bayer` set, a one-channel 8- or 16-bit raw frame, demosaiced edge-aware. Throws
// InputError "<path>: <what was expected>, got <what>" for a float or 32-bit image, a Bayer
// pattern named for a colour image, or any other layout; UnreadableImage for a missing or
// undecodable file.
cv::Mat ReadImage(const std::string& path, BayerPattern bayer = BayerPattern::kNone);

}  // namespace omni::io
