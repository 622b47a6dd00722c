// A faster decoder for the PNG frames `depth --images` reads most (8-bit RGB, as renders and
// screen grabs write them): libdeflate's inflate (~1.6x zlib's on a 5 MP frame) and PNG's five
// row filters, giving exactly cv::imread(path, IMREAD_COLOR)'s BGR pixels (PNG is lossless and
// OpenCV's decoder applies no gamma to 8-bit RGB). Anything else (palette, grey, alpha, 16 bit,
// interlaced, eXIf's orientation, an unknown critical chunk, a bad CRC or stream) is left to
// cv::imread: DecodeRgbPng says so by returning false.
//   5 MP noisy render (9 MB): cv::imread ~105 ms CPU, this ~60 ms.
#pragma once

#include <string>
#include <string_view>

#include <opencv2/core.hpp>

namespace omni::io {

// The file's bytes as a BGR image (CV_8UC3) if it is an 8-bit RGB, non-interlaced PNG whose
// chunks and stream check out; false otherwise (then *image is untouched). Without libdeflate
// at build time, always false.
bool DecodeRgbPng(std::string_view file, cv::Mat* image);

// Whether DecodeRgbPng was built (libdeflate found).
bool HavePngFastPath();

// cv::imread(path, IMREAD_COLOR) through DecodeRgbPng when it applies; empty if unreadable.
cv::Mat ReadColorImage(const std::string& path);

}  // namespace omni::io
