#include "io/file_util.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <system_error>
#include <vector>

namespace omni::io {
namespace {

std::string ParentFolder(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

[[noreturn]] void ThrowWriteError(const std::string& path, const std::string& what) {
  throw std::runtime_error("cannot write '" + path + "': " + what);
}

}  // namespace

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  if (path_.empty()) ThrowWriteError(path_, "empty file name");
  const std::string folder = ParentFolder(path_);
  struct stat st;
  if (::stat(folder.c_str(), &st) != 0) {
    ThrowWriteError(path_, "folder '" + folder + "' " +
                               (errno == ENOENT ? std::string("does not exist")
                                                : std::string(std::strerror(errno))));
  }
  if (!S_ISDIR(st.st_mode)) ThrowWriteError(path_, "'" + folder + "' is not a folder");
  std::vector<char> name(path_.begin(), path_.end());
  static const char kSuffix[] = ".tmp.XXXXXX";
  name.insert(name.end(), kSuffix, kSuffix + sizeof(kSuffix));  // includes the '\0'
  fd_ = ::mkstemp(name.data());
  if (fd_ < 0) {
    ThrowWriteError(path_, "cannot create a file in folder '" + folder +
                               "': " + std::strerror(errno));
  }
  temp_path_ = name.data();
  // mkstemp creates 0600; a model or point list is an ordinary document.
  ::fchmod(fd_, 0644);
}

AtomicFile::~AtomicFile() { Discard(); }

void AtomicFile::Discard() noexcept {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (!temp_path_.empty()) {
    ::unlink(temp_path_.c_str());
    temp_path_.clear();
  }
}

void AtomicFile::Write(std::string_view data) {
  if (fd_ < 0) ThrowWriteError(path_, "file already closed");
  while (!data.empty()) {
    const ssize_t n = ::write(fd_, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      const std::string what = std::strerror(errno);
      Discard();
      ThrowWriteError(path_, what);
    }
    data.remove_prefix(static_cast<std::size_t>(n));
  }
}

void AtomicFile::Commit() {
  if (fd_ < 0) ThrowWriteError(path_, "file already closed");
  // fsync before rename: after a crash the name points either to the old or to the full new file.
  if (::fsync(fd_) != 0 || ::close(fd_) != 0) {
    fd_ = -1;
    const std::string what = std::strerror(errno);
    Discard();
    ThrowWriteError(path_, what);
  }
  fd_ = -1;
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    const std::string what = std::strerror(errno);
    Discard();
    ThrowWriteError(path_, what);
  }
  temp_path_.clear();
}

void WriteFileAtomically(const std::string& path, const std::string& contents) {
  AtomicFile file(path);
  file.Write(contents);
  file.Commit();
}

std::string FormatDouble(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

bool ParseDouble(std::string_view text, double* value) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty() || text.front() == '+') return false;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  if (result.ptr != end) return false;
  if (result.ec == std::errc::result_out_of_range) {
    // from_chars leaves the value unset; strtod gives the saturated value (+-inf or +-0).
    *value = std::strtod(std::string(text).c_str(), nullptr);
    return true;
  }
  return result.ec == std::errc();
}

}  // namespace omni::io
