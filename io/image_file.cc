#include "io/image_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <unistd.h>

#include <filesystem>
#include <mutex>
#include <vector>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace omni::io {
namespace {

// Decodes an image file with the decoders' own messages kept off stderr: libpng prints
// "libpng error: ..." itself for a damaged PNG (OpenCV offers no hook) and OpenCV logs a warning
// for a file it cannot decode. Our one line (UnreadableImage) says it instead. stderr (fd 2) is
// pointed at /dev/null only while decoding, under a lock.
cv::Mat DecodeQuietly(const std::string& path) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  std::fflush(stderr);
  const int saved = ::dup(2);
  const int null = ::open("/dev/null", O_WRONLY);
  if (saved >= 0 && null >= 0) ::dup2(null, 2);
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    image.release();
  }
  std::fflush(stderr);
  if (saved >= 0 && null >= 0) ::dup2(saved, 2);
  if (null >= 0) ::close(null);
  if (saved >= 0) ::close(saved);
  return image;
}

// True for a JPEG file (starts with the SOI marker FF D8) with no end-of-image marker (FF D9)
// near its end: a file cut short in copying. libjpeg decodes such a file with its missing part
// grey, and says so only on stderr.
bool IsTruncatedJpeg(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  unsigned char head[2] = {0, 0};
  const bool jpeg = std::fread(head, 1, 2, f) == 2 && head[0] == 0xFF && head[1] == 0xD8;
  bool end_marker = false;
  if (jpeg) {
    std::fseek(f, 0, SEEK_END);
    const long size = std::ftell(f);
    const long tail = std::min(size, 4096L);  // cameras may pad after the marker
    std::vector<unsigned char> bytes(static_cast<std::size_t>(tail));
    std::fseek(f, size - tail, SEEK_SET);
    const std::size_t got = std::fread(bytes.data(), 1, bytes.size(), f);
    for (std::size_t i = 0; i + 1 < got && !end_marker; ++i) {
      end_marker = bytes[i] == 0xFF && bytes[i + 1] == 0xD9;
    }
  }
  std::fclose(f);
  return jpeg && !end_marker;
}

}  // namespace

double SrgbFromLinear(double linear) {
  const double x = std::clamp(linear, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
}

bool HasHalvedChroma(const std::vector<unsigned char>& bytes) {
  const std::size_t size = bytes.size();
  if (size < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8) return false;
  // Segments up to the first frame header (SOF0-SOF15 but DHT C4, JPG C8, DAC CC) or scan.
  std::size_t i = 2;
  while (i + 1 < size && bytes[i] == 0xFF) {
    while (i + 1 < size && bytes[i + 1] == 0xFF) ++i;  // fill bytes
    const int marker = bytes[i + 1];
    i += 2;
    if (marker == 0xD9 || marker == 0xDA) return false;
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length
    if (i + 2 > size) return false;
    const std::size_t length = (std::size_t{bytes[i]} << 8) | bytes[i + 1];  // with its 2 bytes
    const bool frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
                       marker != 0xCC;
    if (frame) {
      // precision, height (2), width (2), components; per component: id, sampling factors
      // (H << 4 | V), quantisation table. The first component is the luma.
      const std::size_t components = i + 7 < size ? bytes[i + 7] : 0;
      if (components < 3 || i + 8 + 3 * components > size) return false;
      const int luma = bytes[i + 9];
      for (std::size_t c = 1; c < components; ++c) {
        const int chroma = bytes[i + 9 + 3 * c];
        if ((chroma >> 4) < (luma >> 4) || (chroma & 15) < (luma & 15)) return true;
      }
      return false;
    }
    if (length < 2) return false;
    i += length;
  }
  return false;
}

bool HasHalvedChroma(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return false;
  // The frame header follows the metadata segments (EXIF, ICC profiles: at most a few 64 KB).
  std::vector<unsigned char> head(1 << 20);
  head.resize(std::fread(head.data(), 1, head.size(), f));
  std::fclose(f);
  return HasHalvedChroma(head);
}

cv::Mat ReadStoredLuma(const std::string& path) {
  if (!HasHalvedChroma(path)) return cv::Mat();
  return cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_IGNORE_ORIENTATION);
}

cv::Mat ReadStoredLuma(const std::vector<unsigned char>& bytes) {
  if (!HasHalvedChroma(bytes)) return cv::Mat();
  return cv::imdecode(bytes, cv::IMREAD_GRAYSCALE | cv::IMREAD_IGNORE_ORIENTATION);
}

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string Describe(const cv::Mat& m) {
  const int depth = m.depth();
  const std::string bits = depth == CV_8U || depth == CV_8S     ? "8-bit"
                           : depth == CV_16U || depth == CV_16S ? "16-bit"
                           : depth == CV_32F                    ? "32-bit float"
                           : depth == CV_64F                    ? "64-bit float"
                                                                : "32-bit integer";
  return bits + (depth == CV_8S || depth == CV_16S ? " signed" : "") + " image with " +
         std::to_string(m.channels()) + " channel" + (m.channels() == 1 ? "" : "s");
}

}  // namespace

std::optional<BayerPattern> ParseBayerPattern(const std::string& name) {
  const std::string n = Lower(name);
  if (n.empty() || n == "none") return BayerPattern::kNone;
  if (n == "rggb") return BayerPattern::kRGGB;
  if (n == "bggr") return BayerPattern::kBGGR;
  if (n == "grbg") return BayerPattern::kGRBG;
  if (n == "gbrg") return BayerPattern::kGBRG;
  return std::nullopt;
}

std::string BayerName(BayerPattern pattern) {
  switch (pattern) {
    case BayerPattern::kRGGB: return "RGGB";
    case BayerPattern::kBGGR: return "BGGR";
    case BayerPattern::kGRBG: return "GRBG";
    case BayerPattern::kGBRG: return "GBRG";
    case BayerPattern::kNone: break;
  }
  return "none";
}

std::optional<Demosaic> ParseDemosaic(const std::string& name) {
  const std::string n = Lower(name);
  if (n == "bilinear") return Demosaic::kBilinear;
  if (n == "edge_aware" || n == "ea") return Demosaic::kEdgeAware;
  if (n == "vng") return Demosaic::kVng;
  return std::nullopt;
}

std::string DemosaicName(Demosaic demosaic) {
  switch (demosaic) {
    case Demosaic::kBilinear: return "bilinear";
    case Demosaic::kEdgeAware: return "edge_aware";
    case Demosaic::kVng: return "vng";
  }
  return "edge_aware";
}

std::optional<ToneCurve> ParseToneCurve(const std::string& name) {
  const std::string n = Lower(name);
  if (n == "srgb") return ToneCurve::kSrgb;
  if (n == "linear") return ToneCurve::kLinear;
  return std::nullopt;
}

std::string ToneCurveName(ToneCurve tone) { return tone == ToneCurve::kSrgb ? "srgb" : "linear"; }

cv::Mat LinearImage(const cv::Mat& image, ToneCurve tone) {
  CV_Assert(image.depth() == CV_8U || image.depth() == CV_16U);
  cv::Mat out;
  if (tone == ToneCurve::kLinear) {
    image.convertTo(out, CV_16U, image.depth() == CV_8U ? 257.0 : 1.0);
    return out;
  }
  // IEC 61966-2-1's decoding, tabulated for every input level.
  const int levels = image.depth() == CV_8U ? 256 : 65536;
  std::vector<uint16_t> table(levels);
  for (int i = 0; i < levels; ++i) {
    const double e = static_cast<double>(i) / (levels - 1);
    const double l = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
    table[i] = static_cast<uint16_t>(std::lround(l * 65535));
  }
  out.create(image.size(), CV_MAKETYPE(CV_16U, image.channels()));
  const int n = image.cols * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    uint16_t* dst = out.ptr<uint16_t>(y);
    if (image.depth() == CV_8U) {
      const uchar* src = image.ptr<uchar>(y);
      for (int k = 0; k < n; ++k) dst[k] = table[src[k]];
    } else {
      const uint16_t* src = image.ptr<uint16_t>(y);
      for (int k = 0; k < n; ++k) dst[k] = table[src[k]];
    }
  }
  return out;
}

int BayerChannel(BayerPattern pattern, int row, int col) {
  const char* name = pattern == BayerPattern::kRGGB   ? "RGGB"
                     : pattern == BayerPattern::kBGGR ? "BGGR"
                     : pattern == BayerPattern::kGRBG ? "GRBG"
                                                      : "GBRG";
  const char c = name[2 * (row & 1) + (col & 1)];
  return c == 'B' ? 0 : c == 'G' ? 1 : 2;
}

cv::Mat DemosaicImage(const cv::Mat& mosaic, BayerPattern pattern, Demosaic demosaic) {
  CV_Assert(mosaic.channels() == 1 && pattern != BayerPattern::kNone);
  // OpenCV's names follow the second row: our RGGB is its BayerBG (imgproc.hpp's aliases).
  int code = 0;
  switch (demosaic) {
    case Demosaic::kBilinear:
      code = pattern == BayerPattern::kRGGB   ? cv::COLOR_BayerRGGB2BGR
             : pattern == BayerPattern::kBGGR ? cv::COLOR_BayerBGGR2BGR
             : pattern == BayerPattern::kGRBG ? cv::COLOR_BayerGRBG2BGR
                                              : cv::COLOR_BayerGBRG2BGR;
      break;
    case Demosaic::kEdgeAware:
      code = pattern == BayerPattern::kRGGB   ? cv::COLOR_BayerBG2BGR_EA
             : pattern == BayerPattern::kBGGR ? cv::COLOR_BayerRG2BGR_EA
             : pattern == BayerPattern::kGRBG ? cv::COLOR_BayerGB2BGR_EA
                                              : cv::COLOR_BayerGR2BGR_EA;
      break;
    case Demosaic::kVng:
      code = pattern == BayerPattern::kRGGB   ? cv::COLOR_BayerRGGB2BGR_VNG
             : pattern == BayerPattern::kBGGR ? cv::COLOR_BayerBGGR2BGR_VNG
             : pattern == BayerPattern::kGRBG ? cv::COLOR_BayerGRBG2BGR_VNG
                                              : cv::COLOR_BayerGBRG2BGR_VNG;
      break;
  }
  cv::Mat in = mosaic, out;
  if (demosaic == Demosaic::kVng && in.depth() != CV_8U) in.convertTo(in, CV_8U, 1.0 / 257.0);
  cv::cvtColor(in, out, code);
  return out;
}

cv::Mat ReadImage(const std::string& path, BayerPattern bayer) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw UnreadableImage(path + ": cannot read the image: expected an image file, got " +
                     (std::filesystem::exists(path, ec) ? "a folder or special file" : "no such file"));
  }
  if (IsTruncatedJpeg(path)) {
    throw UnreadableImage(path + ": cannot read the image: expected a whole JPEG file, got one "
                                 "cut short (no end-of-image marker)");
  }
  cv::Mat image = DecodeQuietly(path);
  if (image.empty()) {
    throw UnreadableImage(path + ": cannot read the image: expected a PNG, TIFF or JPEG file, got one that cannot be decoded");
  }
  const bool depth_ok = image.depth() == CV_8U || image.depth() == CV_16U;
  if (bayer != BayerPattern::kNone) {
    if (image.channels() != 1 || !depth_ok) {
      throw InputError(path + ": the session names Bayer pattern " + BayerName(bayer) +
                       ", so expected a raw one-channel 8- or 16-bit frame, got a " +
                       Describe(image));
    }
    return DemosaicImage(image, bayer, Demosaic::kEdgeAware);
  }
  const int ch = image.channels();
  if (!depth_ok || (ch != 1 && ch != 3 && ch != 4)) {
    throw InputError(path + ": expected an 8- or 16-bit grey, colour or colour+alpha image, got a " +
                     Describe(image));
  }
  return image;
}

}  // namespace omni::io
