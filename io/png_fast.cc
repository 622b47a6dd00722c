#include "io/png_fast.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#if defined(OMNI_HAVE_LIBDEFLATE)
#include <libdeflate.h>
#endif

namespace omni::io {
namespace {

#if defined(OMNI_HAVE_LIBDEFLATE)
std::uint32_t BigEndian32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}

// PNG's Paeth predictor (the PNG specification, 9.4).
inline int Paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

// Reverses row filter `type` in place (row: the filtered bytes, prior: the row above, unfiltered,
// or zeros), 3 bytes per pixel. False for an unknown filter type.
bool Unfilter(int type, unsigned char* row, const unsigned char* prior, size_t length) {
  constexpr size_t kBpp = 3;
  switch (type) {
    case 0: return true;
    case 1:
      for (size_t i = kBpp; i < length; ++i) {
        row[i] = static_cast<unsigned char>(row[i] + row[i - kBpp]);
      }
      return true;
    case 2:
      for (size_t i = 0; i < length; ++i) row[i] = static_cast<unsigned char>(row[i] + prior[i]);
      return true;
    case 3:
      for (size_t i = 0; i < kBpp; ++i) row[i] = static_cast<unsigned char>(row[i] + prior[i] / 2);
      for (size_t i = kBpp; i < length; ++i) {
        row[i] = static_cast<unsigned char>(row[i] + (row[i - kBpp] + prior[i]) / 2);
      }
      return true;
    case 4:
      for (size_t i = 0; i < kBpp; ++i) row[i] = static_cast<unsigned char>(row[i] + prior[i]);
      for (size_t i = kBpp; i < length; ++i) {
        const int predicted = Paeth(row[i - kBpp], prior[i], prior[i - kBpp]);
        row[i] = static_cast<unsigned char>(row[i] + predicted);
      }
      return true;
    default: return false;
  }
}
#endif

}  // namespace

bool HavePngFastPath() {
#if defined(OMNI_HAVE_LIBDEFLATE)
  return true;
#else
  return false;
#endif
}

bool DecodeRgbPng(std::string_view file, cv::Mat* image) {
#if defined(OMNI_HAVE_LIBDEFLATE)
  static const unsigned char kSignature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
  const auto* bytes = reinterpret_cast<const unsigned char*>(file.data());
  if (file.size() < 8 || std::memcmp(bytes, kSignature, 8) != 0) return false;
  std::uint32_t width = 0, height = 0;
  std::vector<unsigned char> stream;  // the IDAT chunks' data, concatenated
  bool header = false, end = false;
  for (size_t pos = 8; pos + 12 <= file.size() && !end;) {
    const std::uint32_t length = BigEndian32(bytes + pos);
    if (length > file.size() - pos - 12) return false;
    const unsigned char* type = bytes + pos + 4;
    const unsigned char* data = bytes + pos + 8;
    if (libdeflate_crc32(0, type, length + 4) != BigEndian32(data + length)) return false;
    const std::string_view name(reinterpret_cast<const char*>(type), 4);
    if (name == "IHDR") {
      if (length != 13) return false;
      width = BigEndian32(data);
      height = BigEndian32(data + 4);
      // bit depth 8, colour type 2 (RGB), compression 0, filter 0, no interlace
      if (data[8] != 8 || data[9] != 2 || data[10] != 0 || data[11] != 0 || data[12] != 0) {
        return false;
      }
      header = true;
    } else if (name == "IDAT") {
      if (!header) return false;
      stream.insert(stream.end(), data, data + length);
    } else if (name == "IEND") {
      end = true;
    } else if (name == "eXIf" || name == "tRNS" || (type[0] & 0x20) == 0) {
      return false;  // an orientation or transparency imread would use; an unknown critical chunk
    }
    pos += 12 + length;
  }
  if (!header || !end || width == 0 || height == 0 || width > 1u << 16 || height > 1u << 16) {
    return false;
  }
  const size_t row_bytes = 3 * static_cast<size_t>(width);
  std::vector<unsigned char> raw(static_cast<size_t>(height) * (row_bytes + 1));
  libdeflate_decompressor* inflater = libdeflate_alloc_decompressor();
  if (!inflater) return false;
  const libdeflate_result result = libdeflate_zlib_decompress(
      inflater, stream.data(), stream.size(), raw.data(), raw.size(), nullptr);  // exact size
  libdeflate_free_decompressor(inflater);
  if (result != LIBDEFLATE_SUCCESS) return false;
  cv::Mat bgr(static_cast<int>(height), static_cast<int>(width), CV_8UC3);
  const std::vector<unsigned char> zeros(row_bytes, 0);
  const unsigned char* prior = zeros.data();
  for (std::uint32_t y = 0; y < height; ++y) {
    unsigned char* row = raw.data() + y * (row_bytes + 1);
    if (!Unfilter(row[0], row + 1, prior, row_bytes)) return false;
    const unsigned char* rgb = row + 1;
    unsigned char* out = bgr.ptr<unsigned char>(static_cast<int>(y));
    for (size_t x = 0; x < row_bytes; x += 3) {
      out[x] = rgb[x + 2];
      out[x + 1] = rgb[x + 1];
      out[x + 2] = rgb[x];
    }
    prior = rgb;
  }
  *image = bgr;
  return true;
#else
  (void)file;
  (void)image;
  return false;
#endif
}

cv::Mat ReadColorImage(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char signature[8] = {};
  if (in.read(signature, 8) && std::memcmp(signature, "\x89PNG\r\n\x1a\n", 8) == 0) {
    in.seekg(0, std::ios::end);
    std::string file(static_cast<size_t>(in.tellg()), '\0');
    in.seekg(0);
    cv::Mat image;
    if (in.read(file.data(), static_cast<std::streamsize>(file.size())) &&
        DecodeRgbPng(file, &image)) {
      return image;
    }
  }
  return cv::imread(path, cv::IMREAD_COLOR);  // everything else, as before
}

}  // namespace omni::io
