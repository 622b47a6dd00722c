// NumPy's array files, written without NumPy: .npy (format 1.0) and .npz (an uncompressed ZIP of
// .npy members), so that a table exported here loads with numpy alone
// (numpy.load("rays.npy"), numpy.load("maps.npz")["ring1_map_x"]).
//
// .npy layout (numpy/lib/format.py, version 1.0): the magic "\x93NUMPY", the bytes 1 and 0, a
// little-endian uint16 header length, then an ASCII dict literal
// "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 960, 1280, 6), }" padded with spaces and
// ended by '\n' so that the data starts on a 64-byte boundary; then the data in C order,
// little-endian.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace omni::exports {

enum class DType { kFloat32, kFloat64 };

// One array: its member name (.npz only), element type, shape and data (C order; as many
// elements as the shape's product, of DType's size).
struct NpyArray {
  std::string name;
  DType dtype = DType::kFloat64;
  std::vector<int64_t> shape;
  std::vector<float> f32;   // used when dtype is kFloat32
  std::vector<double> f64;  // used when dtype is kFloat64
};

// The .npy file's bytes. Throws std::invalid_argument if the data do not fill the shape.
std::string NpyBytes(const NpyArray& array);

// The .npz file's bytes: one member "<name>.npy" per array, stored (no compression), with its
// CRC-32, as numpy.savez writes them.
std::string NpzBytes(const std::vector<NpyArray>& arrays);

// CRC-32 (ISO-HDLC, ZIP's) of `bytes` (zlib's).
uint32_t Crc32(const std::string& bytes);

}  // namespace omni::exports
