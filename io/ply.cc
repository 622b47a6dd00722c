#include "io/ply.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>

#include "io/file_util.h"

namespace omni::io {
namespace {

constexpr const char* kProperties =
    "property float x\n"
    "property float y\n"
    "property float z\n"
    "property uchar red\n"
    "property uchar green\n"
    "property uchar blue\n"
    "property float sigma_mm\n";
constexpr std::size_t kRecordBytes = 3 * 4 + 3 + 4;

bool LittleEndian() {
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

// `value`'s little-endian bytes at out; returns the byte after them.
template <typename T>
char* Put(T value, char* out) {
  std::memcpy(out, &value, sizeof(T));
  if (!LittleEndian()) std::reverse(out, out + sizeof(T));
  return out + sizeof(T);
}

// A binary vertex record (kProperties' order) at out; returns the byte after it.
char* PutRecord(const PlyPoint& p, char* out) {
  out = Put(p.x, out);
  out = Put(p.y, out);
  out = Put(p.z, out);
  *out++ = static_cast<char>(p.red);
  *out++ = static_cast<char>(p.green);
  *out++ = static_cast<char>(p.blue);
  return Put(p.sigma_mm, out);
}

template <typename T>
T Get(const char* bytes) {
  char copy[sizeof(T)];
  std::memcpy(copy, bytes, sizeof(T));
  if (!LittleEndian()) std::reverse(copy, copy + sizeof(T));
  T value;
  std::memcpy(&value, copy, sizeof(T));
  return value;
}

}  // namespace

void WritePlyFile(const std::string& path, const std::vector<PlyPoint>& points, bool binary) {
  AtomicFile file(path);
  std::ostringstream header;
  header << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
         << "comment omnistereo point cloud, frame C (OpenCV camera), mm; sigma_mm = sqrt of "
            "the largest covariance eigenvalue\n"
         << "element vertex " << points.size() << "\n"
         << kProperties << "end_header\n";
  file.Write(header.str());
  if (binary) {  // whole records into a buffer of fixed size (a 500k-point cloud: ~2 ms)
    constexpr std::size_t kRecordsPerChunk = 1 << 12;
    std::string chunk(kRecordsPerChunk * kRecordBytes, '\0');
    for (std::size_t begin = 0; begin < points.size(); begin += kRecordsPerChunk) {
      const std::size_t end = std::min(points.size(), begin + kRecordsPerChunk);
      char* out = chunk.data();
      for (std::size_t i = begin; i < end; ++i) out = PutRecord(points[i], out);
      file.Write(std::string_view(chunk.data(), static_cast<std::size_t>(out - chunk.data())));
    }
  } else {
    std::string chunk;
    constexpr std::size_t kChunk = 1 << 16;
    for (const PlyPoint& p : points) {
      chunk += FormatDouble(p.x) + " " + FormatDouble(p.y) + " " + FormatDouble(p.z) + " " +
               std::to_string(p.red) + " " + std::to_string(p.green) + " " +
               std::to_string(p.blue) + " " + FormatDouble(p.sigma_mm) + "\n";
      if (chunk.size() >= kChunk) {
        file.Write(chunk);
        chunk.clear();
      }
    }
    file.Write(chunk);
  }
  file.Commit();
}

std::vector<PlyPoint> ReadPlyFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the file");
  std::string line, format;
  long long count = -1;
  std::string properties;
  std::getline(in, line);
  if (line != "ply") throw InputError(path + ": line 1: expected 'ply'");
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "format") words >> format;
    else if (key == "element") {
      std::string name;
      words >> name >> count;
      if (name != "vertex") throw InputError(path + ": header: expected only 'element vertex'");
    } else if (key == "property") {
      properties += line + "\n";
    }
  }
  if (line != "end_header") throw InputError(path + ": header: expected 'end_header'");
  if (properties != kProperties) {
    throw InputError(path + ": header: expected the properties x y z red green blue sigma_mm");
  }
  if (count < 0) throw InputError(path + ": header: expected 'element vertex N'");
  std::vector<PlyPoint> points(static_cast<std::size_t>(count));
  if (format == "binary_little_endian") {
    std::string body(kRecordBytes * points.size(), '\0');
    if (!in.read(body.data(), static_cast<std::streamsize>(body.size()))) {
      throw InputError(path + ": body: expected " + std::to_string(count) + " vertices");
    }
    for (std::size_t i = 0; i < points.size(); ++i) {
      const char* r = body.data() + i * kRecordBytes;
      PlyPoint& p = points[i];
      p.x = Get<float>(r);
      p.y = Get<float>(r + 4);
      p.z = Get<float>(r + 8);
      p.red = static_cast<std::uint8_t>(r[12]);
      p.green = static_cast<std::uint8_t>(r[13]);
      p.blue = static_cast<std::uint8_t>(r[14]);
      p.sigma_mm = Get<float>(r + 15);
    }
  } else if (format == "ascii") {
    for (PlyPoint& p : points) {
      int r = 0, g = 0, b = 0;
      if (!(in >> p.x >> p.y >> p.z >> r >> g >> b >> p.sigma_mm)) {
        throw InputError(path + ": body: expected " + std::to_string(count) + " vertices");
      }
      p.red = static_cast<std::uint8_t>(r);
      p.green = static_cast<std::uint8_t>(g);
      p.blue = static_cast<std::uint8_t>(b);
    }
  } else {
    throw InputError(path + ": header: format: expected binary_little_endian or ascii, got '" +
                     format + "'");
  }
  return points;
}

}  // namespace omni::io
