#include "io/text_append.h"

#include <cstdarg>
#include <cstdio>

namespace omni::io {

void AppendFormat(std::string* out, const char* format, ...) {
  va_list args, size_args;
  va_start(args, format);
  va_copy(size_args, args);
  const int n = std::vsnprintf(nullptr, 0, format, size_args);
  va_end(size_args);
  if (n > 0) {
    const size_t old = out->size();
    out->resize(old + n + 1);
    std::vsnprintf(out->data() + old, n + 1, format, args);
    out->resize(old + n);
  }
  va_end(args);
}

}  // namespace omni::io
