#include "io/csv.h"

#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>

namespace omni::io {
namespace {

constexpr std::size_t kReadChunk = 1 << 20;
constexpr std::size_t kWriteChunk = 1 << 20;

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool IsBlank(std::string_view s) { return Trim(s).empty(); }

std::string Quote(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string out(s.substr(0, kMax));
  if (s.size() > kMax) out += "...";
  return "'" + out + "'";
}

bool HasForbiddenChar(std::string_view s) {
  return s.find_first_of(",\"\n\r") != std::string_view::npos;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// CsvReader

CsvReader::CsvReader(std::string path, std::vector<std::string> columns)
    : path_(std::move(path)), columns_(std::move(columns)) {
  file_.reset(std::fopen(path_.c_str(), "rb"));
  if (file_ == nullptr) {
    const std::string why = errno == ENOENT ? "no such file" : std::strerror(errno);
    throw InputError(path_ + ": expected a readable CSV file, got " + why);
  }
  buffer_.resize(kReadChunk);

  std::string_view line;
  bool found = false;
  while (NextLine(&line)) {
    if (!IsBlank(line)) {
      found = true;
      break;
    }
  }
  std::string wanted;
  for (const std::string& c : columns_) wanted += (wanted.empty() ? "" : ",") + c;
  if (!found) {
    Fail("expected a header row naming the columns (" + wanted + "), got an empty file");
  }
  if (line_ == 1 && line.size() >= 3 && std::memcmp(line.data(), "\xEF\xBB\xBF", 3) == 0) {
    line.remove_prefix(3);
  }
  SplitFields(line);
  for (std::string_view field : fields_) {
    if (field.size() >= 2 && field.front() == '"' && field.back() == '"') {
      field = field.substr(1, field.size() - 2);
    }
    header_.emplace_back(field);
  }
  for (std::size_t i = 0; i < header_.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (header_[i] == header_[j] && !header_[i].empty()) {
        Fail("column '" + header_[i] + "': expected once in the header, got twice");
      }
    }
  }
  std::string got;
  for (const std::string& h : header_) got += (got.empty() ? "" : ",") + h;
  for (const std::string& column : columns_) {
    const int index = ColumnIndex(column);
    if (index < 0) Fail("column '" + column + "': expected in the header, got " + Quote(got));
    column_to_field_.push_back(index);
  }
}

CsvReader::~CsvReader() = default;

int CsvReader::ColumnIndex(std::string_view name) const {
  for (std::size_t i = 0; i < header_.size(); ++i) {
    if (header_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

void CsvReader::Fail(const std::string& what) const {
  throw InputError(path_ + ": line " + std::to_string(line_) + ": " + what);
}

bool CsvReader::NextLine(std::string_view* line) {
  for (;;) {
    const char* start = buffer_.data() + begin_;
    const void* newline = std::memchr(start, '\n', end_ - begin_);
    if (newline != nullptr) {
      const char* stop = static_cast<const char*>(newline);
      *line = std::string_view(start, stop - start);
      begin_ += line->size() + 1;
      ++line_;
      return true;
    }
    if (eof_) {
      if (begin_ == end_) return false;
      *line = std::string_view(start, end_ - begin_);  // last line without '\n'
      begin_ = end_;
      ++line_;
      return true;
    }
    // Keep the partial line, make room (a line longer than the buffer doubles it), read more.
    if (begin_ > 0) {
      std::memmove(buffer_.data(), start, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == buffer_.size()) buffer_.resize(buffer_.size() * 2);
    const std::size_t n = std::fread(buffer_.data() + end_, 1, buffer_.size() - end_, file_.get());
    end_ += n;
    if (n == 0) {
      if (std::ferror(file_.get())) Fail("expected a readable file, got a read error");
      eof_ = true;
    }
  }
}

void CsvReader::SplitFields(std::string_view line) {
  fields_.clear();
  for (;;) {
    const std::size_t comma = line.find(',');
    fields_.push_back(Trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) break;
    line.remove_prefix(comma + 1);
  }
}

bool CsvReader::ReadRow(std::vector<double>* values) {
  std::string_view line;
  do {
    if (!NextLine(&line)) return false;
  } while (IsBlank(line));
  SplitFields(line);
  if (fields_.size() != header_.size()) {
    Fail("expected " + std::to_string(header_.size()) + " comma-separated fields as in the header, got " +
         std::to_string(fields_.size()));
  }
  values->resize(columns_.size());
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    const std::string_view field = fields_[column_to_field_[i]];
    if (!ParseDouble(field, &(*values)[i])) {
      Fail("column '" + columns_[i] + "': expected a number, got " + Quote(field));
    }
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// CsvWriter

CsvWriter::CsvWriter(std::string path, std::vector<std::string> columns)
    : num_columns_(columns.size()) {
  if (columns.empty()) throw std::invalid_argument("CsvWriter: no columns");
  for (const std::string& c : columns) {
    if (c.empty() || HasForbiddenChar(c)) {
      throw std::invalid_argument("CsvWriter: bad column name '" + c + "'");
    }
  }
  file_ = std::make_unique<AtomicFile>(std::move(path));
  buffer_.reserve(kWriteChunk + 4096);
  for (const std::string& c : columns) Add(std::string_view(c));
  EndRow();
}

CsvWriter::~CsvWriter() = default;  // AtomicFile removes the temporary file unless committed

void CsvWriter::Separator() {
  if (fields_in_row_ == num_columns_) {
    throw std::invalid_argument("CsvWriter: more than " + std::to_string(num_columns_) +
                                " fields in a row of " + file_->path());
  }
  if (fields_in_row_ > 0) buffer_ += ',';
  ++fields_in_row_;
}

void CsvWriter::Add(double value) {
  Separator();
  char text[64];
  const auto result = std::to_chars(text, text + sizeof(text), value);
  buffer_.append(text, result.ptr);
}

void CsvWriter::Add(std::string_view text) {
  if (HasForbiddenChar(text)) {
    throw std::invalid_argument("CsvWriter: text field with ',', '\"' or a line break");
  }
  Separator();
  buffer_ += text;
}

void CsvWriter::EndRow() {
  if (fields_in_row_ != num_columns_) {
    throw std::invalid_argument("CsvWriter: row of " + std::to_string(fields_in_row_) +
                                " fields, expected " + std::to_string(num_columns_));
  }
  buffer_ += '\n';
  fields_in_row_ = 0;
  FlushIfFull();
}

void CsvWriter::WriteRow(const double* values, std::size_t count) {
  if (count != num_columns_ || fields_in_row_ != 0) {
    throw std::invalid_argument("CsvWriter: row of " + std::to_string(count) +
                                " values, expected " + std::to_string(num_columns_));
  }
  for (std::size_t i = 0; i < count; ++i) Add(values[i]);
  EndRow();
}

void CsvWriter::FlushIfFull() {
  if (buffer_.size() >= kWriteChunk) {
    file_->Write(buffer_);
    buffer_.clear();
  }
}

void CsvWriter::Commit() {
  if (fields_in_row_ != 0) throw std::invalid_argument("CsvWriter: Commit() inside a row");
  file_->Write(buffer_);
  buffer_.clear();
  file_->Commit();
}

void WriteLabelledCsv(const std::string& path, std::vector<std::string> columns,
                      const std::vector<LabelledRow>& rows) {
  CsvWriter out(path, std::move(columns));
  for (const auto& [label, values] : rows) {
    out.Add(label);
    for (double value : values) out.Add(value);
    out.EndRow();
  }
  out.Commit();
}

}  // namespace omni::io
