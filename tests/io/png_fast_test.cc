// io/png_fast.h against cv::imread (libpng: the independent oracle) on PNGs whose every row
// filter we choose (our own filtering, zlib's deflate), on cv::imwrite's PNGs (libpng's adaptive
// filters) and on the files the fast path must leave to cv::imread.
#include "io/png_fast.h"

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <zlib.h>

#include "tests/temp_dir.h"

namespace omni::io {
namespace {

void PutBigEndian32(std::uint32_t value, std::string* out) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<char>(value >> shift));
}

void PutChunk(const char* type, const std::string& data, std::string* png) {
  PutBigEndian32(static_cast<std::uint32_t>(data.size()), png);
  const std::string typed = std::string(type, 4) + data;
  png->append(typed);
  PutBigEndian32(static_cast<std::uint32_t>(
                     crc32(0, reinterpret_cast<const Bytef*>(typed.data()), typed.size())),
                 png);
}

// An 8-bit RGB PNG of `bgr`, row y filtered with filters[y % size] (the PNG specification's
// filters, written out here independently of png_fast.cc's inverses).
std::string EncodePng(const cv::Mat& bgr, const std::vector<int>& filters) {
  const size_t row_bytes = 3 * static_cast<size_t>(bgr.cols);
  std::vector<unsigned char> raw, prior(row_bytes, 0), row(row_bytes);
  for (int y = 0; y < bgr.rows; ++y) {
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3b c = bgr.at<cv::Vec3b>(y, x);
      row[3 * x] = c[2], row[3 * x + 1] = c[1], row[3 * x + 2] = c[0];
    }
    const int type = filters[y % filters.size()];
    raw.push_back(static_cast<unsigned char>(type));
    for (size_t i = 0; i < row_bytes; ++i) {
      const int a = i >= 3 ? row[i - 3] : 0, b = prior[i], c = i >= 3 ? prior[i - 3] : 0;
      int predicted = 0;
      if (type == 1) predicted = a;
      if (type == 2) predicted = b;
      if (type == 3) predicted = (a + b) / 2;
      if (type == 4) {
        const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
        predicted = pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
      }
      raw.push_back(static_cast<unsigned char>(row[i] - predicted));
    }
    prior = row;
  }
  uLongf size = compressBound(raw.size());
  std::string deflated(size, '\0');
  compress(reinterpret_cast<Bytef*>(deflated.data()), &size, raw.data(), raw.size());
  deflated.resize(size);
  std::string png = "\x89PNG\r\n\x1a\n", header;
  PutBigEndian32(bgr.cols, &header);
  PutBigEndian32(bgr.rows, &header);
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bit, RGB, deflate, filter 0, no interlace
  PutChunk("IHDR", header, &png);
  PutChunk("IDAT", deflated.substr(0, deflated.size() / 2), &png);  // two IDATs
  PutChunk("IDAT", deflated.substr(deflated.size() / 2), &png);
  PutChunk("IEND", "", &png);
  return png;
}

cv::Mat TestImage(int width, int height) {  // noise over gradients: every filter is exercised
  cv::Mat image(height, width, CV_8UC3);
  cv::randu(image, 0, 256);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width / 2; ++x) image.at<cv::Vec3b>(y, x) = cv::Vec3b(x, y, x + y);
  }
  return image;
}

std::string WriteFile(const std::string& name, const std::string& bytes) {
  const std::filesystem::path dir = omni::testing::UniqueTempDir("png_fast");
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(PngFast, EveryRowFilterGivesImreadsPixels) {
  if (!HavePngFastPath()) GTEST_SKIP() << "built without libdeflate";
  const cv::Mat image = TestImage(101, 37);  // odd sizes
  for (const std::vector<int>& filters :
       {std::vector<int>{0}, {1}, {2}, {3}, {4}, {0, 1, 2, 3, 4}, {4, 3, 2, 1, 0, 2}}) {
    const std::string png = EncodePng(image, filters);
    const std::string path = WriteFile("filters.png", png);
    const cv::Mat oracle = cv::imread(path, cv::IMREAD_COLOR);
    ASSERT_TRUE(Same(oracle, image));  // our encoder is right
    cv::Mat fast;
    ASSERT_TRUE(DecodeRgbPng(png, &fast)) << filters.size();
    EXPECT_TRUE(Same(fast, oracle)) << "filters " << filters[0] << " (" << filters.size() << ")";
    EXPECT_TRUE(Same(ReadColorImage(path), oracle));
  }
}

TEST(PngFast, ImwritesPngsGiveImreadsPixels) {
  if (!HavePngFastPath()) GTEST_SKIP() << "built without libdeflate";
  const cv::Mat image = TestImage(640, 48);
  for (int level : {1, 9}) {
    const std::string path = WriteFile("imwrite.png", "");
    ASSERT_TRUE(cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, level}));
    std::ifstream in(path, std::ios::binary);
    const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    cv::Mat fast;
    ASSERT_TRUE(DecodeRgbPng(file, &fast));
    EXPECT_TRUE(Same(fast, cv::imread(path, cv::IMREAD_COLOR))) << level;
  }
}

TEST(PngFast, OtherFilesAreLeftToImread) {
  const cv::Mat image = TestImage(64, 32);
  cv::Mat grey, bgra, deep;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(image, bgra, cv::COLOR_BGR2BGRA);
  image.convertTo(deep, CV_16UC3, 257);
  for (const auto& [name, mat] : std::vector<std::pair<std::string, cv::Mat>>{
           {"grey.png", grey}, {"bgra.png", bgra}, {"deep.png", deep}, {"photo.jpg", image}}) {
    const std::string path = WriteFile(name, "");
    ASSERT_TRUE(cv::imwrite(path, mat));
    std::ifstream in(path, std::ios::binary);
    const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    cv::Mat fast;
    EXPECT_FALSE(DecodeRgbPng(file, &fast)) << name;
    EXPECT_TRUE(Same(ReadColorImage(path), cv::imread(path, cv::IMREAD_COLOR))) << name;
  }
  // A flipped bit in the pixel data: the chunk's CRC fails; imread's verdict stands.
  std::string png = EncodePng(image, {1});
  png[60] = static_cast<char>(png[60] ^ 1);
  cv::Mat fast;
  EXPECT_FALSE(DecodeRgbPng(png, &fast));
  const std::string path = WriteFile("corrupt.png", png);
  EXPECT_TRUE(Same(ReadColorImage(path), cv::imread(path, cv::IMREAD_COLOR)));
  EXPECT_TRUE(ReadColorImage(WriteFile("empty.png", "")).empty());
  EXPECT_TRUE(ReadColorImage("/nonexistent/frame.png").empty());
}

}  // namespace
}  // namespace omni::io
