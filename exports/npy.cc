#include "exports/npy.h"

#include <cstring>
#include <stdexcept>

#include <zlib.h>

namespace omni::exports {
namespace {

void PutLe(std::string* out, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

std::string Header(const NpyArray& a) {
  std::string shape = "(";
  for (size_t i = 0; i < a.shape.size(); ++i) shape += std::to_string(a.shape[i]) + ", ";
  if (a.shape.size() > 1) shape.resize(shape.size() - 2);  // "(n,)" keeps its comma
  if (a.shape.size() == 1) shape.resize(shape.size() - 1);
  shape += ")";
  std::string dict = std::string("{'descr': '") +
                     (a.dtype == DType::kFloat32 ? "<f4" : "<f8") +
                     "', 'fortran_order': False, 'shape': " + shape + ", }";
  // 10 bytes of magic, version and length before the dict; pad to 64 with the final '\n'.
  const size_t total = 10 + dict.size() + 1;
  dict.append((64 - total % 64) % 64, ' ');
  dict.push_back('\n');
  return dict;
}

}  // namespace

std::string NpyBytes(const NpyArray& a) {
  int64_t count = 1;
  for (int64_t n : a.shape) count *= n;
  const size_t have = a.dtype == DType::kFloat32 ? a.f32.size() : a.f64.size();
  if (count < 0 || static_cast<size_t>(count) != have) {
    throw std::invalid_argument("npy array '" + a.name + "': " + std::to_string(have) +
                                " elements for a shape of " + std::to_string(count));
  }
  const std::string header = Header(a);
  std::string out = "\x93NUMPY";
  out.push_back(1);
  out.push_back(0);
  PutLe(&out, header.size(), 2);
  out += header;
  // x86-64 and aarch64 are little-endian, the order '<' names.
  if (a.dtype == DType::kFloat32) {
    out.append(reinterpret_cast<const char*>(a.f32.data()), a.f32.size() * sizeof(float));
  } else {
    out.append(reinterpret_cast<const char*>(a.f64.data()), a.f64.size() * sizeof(double));
  }
  return out;
}

uint32_t Crc32(const std::string& bytes) {
  return static_cast<uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())));
}

// ZIP (APPNOTE 6.3): per member a local header and the stored bytes, then the central directory
// and its end record. Members and the archive stay under 4 GiB (no ZIP64): a 1280x960 ray table
// in float64 is 118 MB.
std::string NpzBytes(const std::vector<NpyArray>& arrays) {
  std::string out, directory;
  for (const NpyArray& a : arrays) {
    const std::string data = NpyBytes(a);
    const std::string name = a.name + ".npy";
    if (out.size() + data.size() > 0xFFFFFFFFull) {
      throw std::invalid_argument("npz: the archive would exceed 4 GiB");
    }
    const uint32_t crc = Crc32(data), offset = static_cast<uint32_t>(out.size());
    auto common = [&](std::string* h) {
      PutLe(h, 20, 2);  // version needed: 2.0
      PutLe(h, 0, 2);   // flags
      PutLe(h, 0, 2);   // method: stored
      PutLe(h, 0, 2);   // time
      PutLe(h, 0x21, 2);  // date: 1980-01-01
      PutLe(h, crc, 4);
      PutLe(h, data.size(), 4);
      PutLe(h, data.size(), 4);
      PutLe(h, name.size(), 2);
      PutLe(h, 0, 2);  // extra field length
    };
    PutLe(&out, 0x04034b50, 4);
    common(&out);
    out += name;
    out += data;
    PutLe(&directory, 0x02014b50, 4);
    PutLe(&directory, 20, 2);  // version made by
    common(&directory);
    PutLe(&directory, 0, 2);  // comment length
    PutLe(&directory, 0, 2);  // disk
    PutLe(&directory, 0, 2);  // internal attributes
    PutLe(&directory, 0, 4);  // external attributes
    PutLe(&directory, offset, 4);
    directory += name;
  }
  const uint32_t directory_offset = static_cast<uint32_t>(out.size());
  out += directory;
  PutLe(&out, 0x06054b50, 4);
  PutLe(&out, 0, 2);
  PutLe(&out, 0, 2);
  PutLe(&out, arrays.size(), 2);
  PutLe(&out, arrays.size(), 2);
  PutLe(&out, directory.size(), 4);
  PutLe(&out, directory_offset, 4);
  PutLe(&out, 0, 2);
  return out;
}

}  // namespace omni::exports
