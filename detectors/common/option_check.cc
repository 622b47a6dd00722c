#include "detectors/common/option_check.h"

#include <cstdio>

namespace omni::detectors {

std::string OptionError(const std::string& field, const std::string& expected, double got) {
  char value[32];
  std::snprintf(value, sizeof value, "%g", got);
  return field + ": expected " + expected + ", got " + value;
}

std::string NestedOptionError(const std::string& prefix, const std::string& inner) {
  return inner.empty() ? inner : prefix + "." + inner;
}

}  // namespace omni::detectors
