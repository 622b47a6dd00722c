#include "synthetic/tag_texture.h"

#include <cmath>
#include <memory>
#include <stdexcept>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/file_util.h"

namespace omni::synthetic {
namespace {

constexpr int kMaxPixelsPerBit = 64;

using Family = std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)>;

Family Tag36h11() { return Family(tag36h11_create(), tag36h11_destroy); }

// Tag `index` of the family as width_at_border x width_at_border bits (0 black, 255 white): the
// black border and the data bits where libapriltag's apriltag_to_image puts them (bit i of the
// code, most significant first, at (bit_x[i], bit_y[i]) from the black square's top-left).
cv::Mat TagBits(const apriltag_family_t& family, int index) {
  const int n = family.width_at_border;
  cv::Mat bits(n, n, CV_8UC1, cv::Scalar(0));
  const uint64_t code = family.codes[index];
  for (uint32_t i = 0; i < family.nbits; ++i) {
    if (code & (uint64_t{1} << (family.nbits - i - 1))) {
      bits.at<uint8_t>(family.bit_y[i], family.bit_x[i]) = 255;
    }
  }
  return bits;
}

}  // namespace

int TagBitsAcross(const TargetSpec& spec) {
  return spec.type == TargetType::kKalibrAprilGrid ? 10 : 8;
}

int TexturePixelsPerBit(const TargetSpec& spec, int min_pixels_per_bit) {
  const double gap_bits = spec.spacing * TagBitsAcross(spec);
  for (int n = std::max(1, min_pixels_per_bit); n <= kMaxPixelsPerBit; ++n) {
    const double gap_pixels = gap_bits * n;
    if (std::abs(gap_pixels - std::round(gap_pixels)) < 1e-6) return n;
  }
  return 0;
}

bool CheckTagGrid(const TargetSpec& spec, std::string* error) {
  if (spec.type == TargetType::kChessboard) {
    *error = "expected a tag grid";
    return false;
  }
  if (spec.family != "tag36h11") {
    *error = "family: expected tag36h11, got '" + spec.family + "'";
    return false;
  }
  if (spec.rows < 1 || spec.cols < 1 || !(spec.tag_size_mm > 0)) {
    *error = "expected rows, cols >= 1 and tag_size > 0";
    return false;
  }
  const int bits = TagBitsAcross(spec);
  if (!(spec.spacing > 0) || spec.spacing > 1 ||
      (spec.type == TargetType::kAprilTagGrid && spec.spacing * bits < 1 - 1e-9)) {
    *error = spec.type == TargetType::kAprilTagGrid
                 ? "spacing: expected 0.125..1 (at least one white tag bit between tags)"
                 : "spacing: expected 0 < spacing <= 1 (gap / tag_size)";
    return false;
  }
  const Family family = Tag36h11();
  if (spec.first_id < 0 ||
      spec.first_id + spec.rows * spec.cols > static_cast<int>(family->ncodes)) {
    *error = "first_id: expected ids first_id .. first_id + rows * cols - 1 inside tag36h11's 0.." +
             std::to_string(family->ncodes - 1);
    return false;
  }
  if (TexturePixelsPerBit(spec, 1) == 0) {
    *error = "spacing: spacing * " + std::to_string(bits) +
             " bits must be a multiple of 1/64 bit (e.g. 0.25, 0.3) to be printed exactly";
    return false;
  }
  return true;
}

TagTexture MakeTagTexture(const TargetSpec& spec, int min_pixels_per_bit) {
  std::string error;
  if (!CheckTagGrid(spec, &error)) throw std::invalid_argument("MakeTagTexture: " + error);
  const int bits = TagBitsAcross(spec);
  const int n = TexturePixelsPerBit(spec, min_pixels_per_bit);
  if (n == 0) throw std::invalid_argument("MakeTagTexture: no exact pixel size");
  const int tag_px = bits * n;
  const int gap_px = static_cast<int>(std::lround(spec.spacing * bits * n));
  const int margin_px = gap_px + n;  // SheetBounds: one gap and one tag bit of white
  const int pitch_px = tag_px + gap_px;
  TagTexture texture;
  texture.pixels_per_bit = n;
  texture.mm_per_pixel = spec.tag_size_mm / tag_px;
  texture.image = cv::Mat(2 * margin_px + spec.rows * tag_px + (spec.rows - 1) * gap_px,
                          2 * margin_px + spec.cols * tag_px + (spec.cols - 1) * gap_px, CV_8UC1,
                          cv::Scalar(255));
  const bool kalibr = spec.type == TargetType::kKalibrAprilGrid;
  if (kalibr) {
    // kalibr_create_target_pdf's squares at each tag's diagonal corners: every gap crossing.
    for (int r = 0; r <= spec.rows; ++r) {
      for (int c = 0; c <= spec.cols; ++c) {
        texture.image(cv::Rect(margin_px - gap_px + c * pitch_px, margin_px - gap_px + r * pitch_px,
                               gap_px, gap_px))
            .setTo(0);
      }
    }
  }
  const Family family = Tag36h11();
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const cv::Mat lib_bits = TagBits(*family, TagIdAt(spec, r, c));
      // Kalibr: the data bits (inside libapriltag's 1-bit border) in a 2-bit black border.
      cv::Mat tag_bits(bits, bits, CV_8UC1, cv::Scalar(0));
      if (kalibr) {
        const int data = lib_bits.rows - 2;
        lib_bits(cv::Rect(1, 1, data, data)).copyTo(tag_bits(cv::Rect(2, 2, data, data)));
      } else {
        lib_bits.copyTo(tag_bits);
      }
      cv::Mat tag_px_image;
      cv::resize(tag_bits, tag_px_image, cv::Size(tag_px, tag_px), 0, 0, cv::INTER_NEAREST);
      tag_px_image.copyTo(
          texture.image(cv::Rect(margin_px + c * pitch_px, margin_px + r * pitch_px, tag_px, tag_px)));
    }
  }
  return texture;
}

TagTexture SheetTexture(const TargetSpec& spec) {
  if (spec.type != TargetType::kChessboard) return MakeTagTexture(spec);
  if (spec.rows < 1 || spec.cols < 1 || !(spec.square_mm > 0)) {
    throw std::invalid_argument("SheetTexture: expected rows, cols >= 1 and square > 0");
  }
  TagTexture texture;
  texture.mm_per_pixel = spec.square_mm;
  texture.pixels_per_bit = 1;
  // SheetBounds: x from -2 squares to cols + 1 squares; pixel column k covers cell i = k - 2.
  texture.image = cv::Mat(spec.rows + 3, spec.cols + 3, CV_8UC1, cv::Scalar(255));
  for (int j = -1; j < spec.rows; ++j) {
    for (int i = -1; i < spec.cols; ++i) {
      if ((i + j) % 2 != 0) texture.image.at<uint8_t>(j + 2, i + 2) = 0;
    }
  }
  return texture;
}

std::string TextureFileName(int index, const TargetSpec& spec) {
  return "target" + std::to_string(index) + "_" + TargetTypeName(spec.type) + ".png";
}

bool WriteTagTextures(const std::vector<TargetSpec>& targets, const std::string& folder,
                      std::string* error) {
  for (size_t i = 0; i < targets.size(); ++i) {
    if (targets[i].type == TargetType::kChessboard) continue;
    const std::string path = folder + "/" + TextureFileName(static_cast<int>(i), targets[i]);
    std::vector<uchar> png;
    try {
      if (!cv::imencode(".png", MakeTagTexture(targets[i]).image, png)) {
        *error = "cannot encode " + path;
        return false;
      }
      io::WriteFileAtomically(path, std::string(png.begin(), png.end()));
    } catch (const std::exception& e) {
      *error = path + ": " + e.what();
      return false;
    }
  }
  return true;
}

}  // namespace omni::synthetic
