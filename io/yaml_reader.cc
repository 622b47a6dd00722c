#include "io/yaml_reader.h"

#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>
#include <sys/stat.h>

namespace omni::io {

void CheckFormat(const Reader& in, const YAML::Node& root, const char* kFormatPrefix,
                 int kFormatMajor) {
  const YAML::Node node = root["format"];
  const std::string expected = "expected '" + std::string(kFormatPrefix) +
                               std::to_string(kFormatMajor) + "' (any 1.x minor version)";
  if (!IsScalar(node)) in.Fail("format", expected, Describe(node));
  const std::string& text = node.Scalar();
  const std::size_t prefix_len = std::strlen(kFormatPrefix);
  if (text.compare(0, prefix_len, kFormatPrefix) != 0) in.Fail("format", expected, Describe(node));
  // The version is MAJOR or MAJOR.MINOR; only the major version changes the meaning of keys.
  const std::string_view version = std::string_view(text).substr(prefix_len);
  int major = -1;
  const char* end = version.data() + version.size();
  const auto result = std::from_chars(version.data(), end, major);
  bool well_formed = result.ec == std::errc() && result.ptr != version.data();
  if (well_formed && result.ptr != end) {
    int minor = 0;
    const auto minor_result =
        result.ptr[0] == '.' ? std::from_chars(result.ptr + 1, end, minor)
                             : std::from_chars_result{result.ptr, std::errc::invalid_argument};
    well_formed = minor_result.ec == std::errc() && minor_result.ptr == end;
  }
  if (!well_formed) in.Fail("format", expected, Describe(node));
  if (major != kFormatMajor) {
    in.Fail("format",
            "expected major version " + std::to_string(kFormatMajor) +
                " (this program reads " + std::string(kFormatPrefix) + std::to_string(kFormatMajor) + ".x)",
            "unknown version " + Describe(node));
  }
}

std::string ReadWholeFile(const std::string& path, const std::string& what) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) {
    const std::string why = errno == ENOENT ? "no such file" : std::strerror(errno);
    throw InputError(path + ": expected a readable " + what + ", got " + why);
  }
  if (S_ISDIR(st.st_mode)) throw InputError(path + ": expected a " + what + ", got a folder");
  std::ifstream stream(path, std::ios::binary);
  if (!stream) {
    throw InputError(path + ": expected a readable " + what + ", got " + std::strerror(errno));
  }
  std::ostringstream contents;
  contents << stream.rdbuf();
  if (stream.bad()) throw InputError(path + ": expected a readable " + what + ", got a read error");
  return contents.str();
}

YAML::Node LoadYamlFile(const std::string& path, const std::string& what) {
  const std::string text = ReadWholeFile(path, what);
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    // yaml-cpp counts lines and columns from 0.
    throw InputError(path + ": line " + std::to_string(e.mark.line + 1) + ", column " +
                     std::to_string(e.mark.column + 1) + ": expected valid YAML, got " + e.msg);
  }
}

std::string ReadFormatKey(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "file");
  if (!IsMap(root) || !IsScalar(root["format"])) return "";
  return root["format"].Scalar();
}

}  // namespace omni::io
