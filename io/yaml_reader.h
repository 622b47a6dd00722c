// The YAML reader every io/ file reader shares: each accessor knows the file and the key
// path, so each error is one complete line "<file>: <key>: <expected>, got <what>" (InputError).
#pragma once

#include <charconv>
#include <cmath>
#include <string_view>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "io/file_util.h"

namespace omni::io {

inline constexpr double kRadPerDeg = M_PI / 180.0;

inline std::string Abbreviate(const std::string& text) {
  constexpr std::size_t kMax = 40;
  std::string out = text.size() > kMax ? text.substr(0, kMax) + "..." : text;
  for (char& ch : out) {
    if (ch == '\n' || ch == '\r' || ch == '\t') ch = ' ';
  }
  return "'" + out + "'";
}

inline std::string Describe(const YAML::Node& node) {
  if (!node.IsDefined()) return "nothing (key missing)";
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "an empty value";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Scalar:
      return node.Tag() == "!" ? "the quoted text " + Abbreviate(node.Scalar())
                               : Abbreviate(node.Scalar());
    default:
      return "nothing (key missing)";
  }
}

// yaml-cpp throws InvalidNode when asked the type of a missing key; these ask IsDefined() first.
inline bool IsMap(const YAML::Node& node) { return node.IsDefined() && node.IsMap(); }
inline bool IsScalar(const YAML::Node& node) { return node.IsDefined() && node.IsScalar(); }
inline bool IsSequence(const YAML::Node& node) { return node.IsDefined() && node.IsSequence(); }

inline std::string Join(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& expected,
                         const std::string& got) const {
    throw InputError(file_ + ": " + key + ": " + expected + ", got " + got);
  }

  // A child map; `key` is the full path of the child.
  YAML::Node Map(const YAML::Node& parent, const std::string& key, const char* name) const {
    YAML::Node node = parent[name];
    if (!IsMap(node)) Fail(key, "expected a map of keys", Describe(node));
    return node;
  }

  double Number(const YAML::Node& node, const std::string& key) const {
    if (!IsScalar(node) || node.Tag() == "!") Fail(key, "expected a number", Describe(node));
    double value = 0;
    if (!ParseYamlNumber(node.Scalar(), &value)) Fail(key, "expected a number", Describe(node));
    if (!std::isfinite(value)) Fail(key, "expected a finite number", Describe(node));
    return value;
  }
  double Number(const YAML::Node& map, const std::string& path, const char* name) const {
    return Number(map[name], Join(path, name));
  }

  double Positive(const YAML::Node& map, const std::string& path, const char* name) const {
    const double value = Number(map, path, name);
    if (!(value > 0)) Fail(Join(path, name), "expected a number > 0", Describe(map[name]));
    return value;
  }

  // An angle in radians under `name`, or in degrees under `name`_deg (docs/design.md, Conventions).
  double Angle(const YAML::Node& map, const std::string& path, const char* name) const {
    const std::string deg_name = std::string(name) + "_deg";
    const bool has_rad = map[name].IsDefined();
    const bool has_deg = map[deg_name].IsDefined();
    if (has_rad && has_deg) {
      Fail(Join(path, name), "expected either " + std::string(name) + " (rad) or " + deg_name,
           "both");
    }
    if (has_deg) return Number(map[deg_name], Join(path, deg_name)) * kRadPerDeg;
    return Number(map, path, name);
  }

  int Integer(const YAML::Node& map, const std::string& path, const char* name, int min) const {
    const YAML::Node node = map[name];
    const std::string key = Join(path, name);
    if (!IsScalar(node) || node.Tag() == "!") Fail(key, "expected an integer", Describe(node));
    std::string_view text = node.Scalar();
    if (!text.empty() && text.front() == '+') text.remove_prefix(1);
    int value = 0;
    const char* end = text.data() + text.size();
    const auto result = std::from_chars(text.data(), end, value);
    if (text.empty() || result.ptr != end || result.ec != std::errc()) {
      Fail(key, "expected an integer", Describe(node));
    }
    if (value < min) Fail(key, "expected an integer >= " + std::to_string(min), Describe(node));
    return value;
  }

  bool Bool(const YAML::Node& map, const std::string& path, const char* name) const {
    const YAML::Node node = map[name];
    const std::string key = Join(path, name);
    if (IsScalar(node) && node.Tag() != "!") {
      const std::string& t = node.Scalar();
      if (t == "true" || t == "True" || t == "TRUE") return true;
      if (t == "false" || t == "False" || t == "FALSE") return false;
    }
    Fail(key, "expected true or false", Describe(node));
  }

  std::string String(const YAML::Node& node, const std::string& key) const {
    if (!IsScalar(node)) Fail(key, "expected a text value", Describe(node));
    return node.Scalar();
  }
  std::string String(const YAML::Node& map, const std::string& path, const char* name) const {
    return String(map[name], Join(path, name));
  }

  std::vector<double> Numbers(const YAML::Node& map, const std::string& path,
                              const char* name) const {
    const YAML::Node node = map[name];
    const std::string key = Join(path, name);
    if (!IsSequence(node)) Fail(key, "expected a list of numbers", Describe(node));
    std::vector<double> values;
    values.reserve(node.size());
    for (std::size_t i = 0; i < node.size(); ++i) {
      values.push_back(Number(node[i], key + "[" + std::to_string(i) + "]"));
    }
    return values;
  }

  std::vector<std::string> Strings(const YAML::Node& map, const std::string& path,
                                   const char* name) const {
    const YAML::Node node = map[name];
    const std::string key = Join(path, name);
    if (!IsSequence(node)) Fail(key, "expected a list of names", Describe(node));
    std::vector<std::string> values;
    for (std::size_t i = 0; i < node.size(); ++i) {
      values.push_back(String(node[i], key + "[" + std::to_string(i) + "]"));
    }
    return values;
  }

  // Numbers are parsed here rather than by yaml-cpp so that the text must be a number in full
  // and reads back exactly what FormatDouble wrote.
  static bool ParseYamlNumber(const std::string& text, double* value) {
    static const char* const kInf[] = {".inf", ".Inf", ".INF"};
    static const char* const kNan[] = {".nan", ".NaN", ".NAN"};
    std::string_view body = text;
    double sign = 1;
    if (!body.empty() && (body.front() == '+' || body.front() == '-')) {
      sign = body.front() == '-' ? -1 : 1;
      body.remove_prefix(1);
    }
    for (const char* inf : kInf) {
      if (body == inf) {
        *value = sign * HUGE_VAL;
        return true;
      }
    }
    for (const char* nan : kNan) {
      if (text == nan) {
        *value = NAN;
        return true;
      }
    }
    return ParseDouble(text, value);
  }

 private:
  std::string file_;
};

// Checks `format: <prefix><major>[.<minor>]` (docs/design.md, Conventions: unknown major versions are rejected).
void CheckFormat(const Reader& in, const YAML::Node& root, const char* prefix, int major);

// The whole file; InputError "<path>: expected a readable <what>, got ..." otherwise.
std::string ReadWholeFile(const std::string& path, const std::string& what);

// The file parsed as YAML; InputError with the line and column of a syntax error.
YAML::Node LoadYamlFile(const std::string& path, const std::string& what);

// The value of a YAML file's top-level `format:` key ("" if it has none); throws InputError for
// an unreadable file or invalid YAML.
std::string ReadFormatKey(const std::string& path);

}  // namespace omni::io
