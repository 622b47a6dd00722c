// Streaming CSV point lists (docs/design.md, Conventions): a header row naming the columns, then one row of
// numbers per line. The reader holds one buffer, not the file, so million-row lists stream; the
// writer writes to a temporary file that only Commit() renames into place.
//
// Dialect: fields separated by ',', no quoting; spaces around fields and '\r' before '\n' are
// ignored; blank lines are skipped; an UTF-8 byte-order mark before the header is skipped.
// Numbers are read with std::from_chars ("nan" and "inf" are numbers; callers that need finite
// values check) and written as the shortest text that reads back bit-for-bit.
#pragma once

#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "io/file_util.h"  // InputError, AtomicFile

namespace omni::io {

class CsvReader {
 public:
  // Opens `path` and reads its header. `columns` are the required columns, found by name in any
  // order; other columns are allowed and skipped. Throws InputError if the file cannot be read,
  // has no header, or lacks a required column:
  //   "<file>: line 1: column 'z_mm': expected in the header, got 'x_mm,y_mm'".
  CsvReader(std::string path, std::vector<std::string> columns);
  ~CsvReader();
  CsvReader(const CsvReader&) = delete;
  CsvReader& operator=(const CsvReader&) = delete;

  // Reads the next row: `values` receives one number per required column, in the order of
  // `columns`. Returns false at the end of the file. Throws InputError for a bad row:
  //   "<file>: line N: column 'x_mm': expected a number, got 'abc'".
  bool ReadRow(std::vector<double>* values);

  // The header's column names, in file order.
  const std::vector<std::string>& header() const { return header_; }
  // Index of a column in header(), or -1.
  int ColumnIndex(std::string_view name) const;
  // Raw text (trimmed) of a field of the last row read, by header index; valid until the next
  // ReadRow(). For non-numeric extra columns (e.g. an image name).
  std::string_view Field(int header_index) const { return fields_.at(header_index); }
  // 1-based line number of the last row read (for the caller's own messages).
  std::int64_t line() const { return line_; }
  const std::string& path() const { return path_; }

 private:
  bool NextLine(std::string_view* line);  // false at end of file
  void SplitFields(std::string_view line);
  [[noreturn]] void Fail(const std::string& what) const;

  std::string path_;
  std::vector<std::string> columns_;
  // Owned so that it is closed when the constructor throws too (a bad header leaked it).
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_{nullptr, &std::fclose};
  std::vector<char> buffer_;
  std::size_t begin_ = 0, end_ = 0;  // unread bytes are buffer_[begin_, end_)
  bool eof_ = false;
  std::int64_t line_ = 0;
  std::vector<std::string> header_;
  std::vector<int> column_to_field_;  // for each required column, its header index
  std::vector<std::string_view> fields_;
};

class CsvWriter {
 public:
  // Writes the header to a temporary file beside `path`; throws std::runtime_error naming
  // `path` if its folder does not exist or is not writable, std::invalid_argument if a column
  // name contains ',', '"' or a line break.
  CsvWriter(std::string path, std::vector<std::string> columns);
  // Without a successful Commit(), removes the temporary file: nothing half-written is left and
  // an existing file at `path` is untouched.
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  // One row of columns().size() numbers (std::invalid_argument otherwise).
  void WriteRow(const double* values, std::size_t count);
  void WriteRow(const std::vector<double>& values) { WriteRow(values.data(), values.size()); }
  void WriteRow(std::initializer_list<double> values) { WriteRow(values.begin(), values.size()); }

  // Field-by-field writing, for rows that mix numbers and text (e.g. an image name). Text must
  // not contain ',', '"' or line breaks (std::invalid_argument). EndRow() checks the count.
  void Add(double value);
  void Add(std::string_view text);
  void EndRow();

  // Flushes and renames the file onto `path`; throws std::runtime_error on failure.
  void Commit();

  std::size_t columns() const { return num_columns_; }

 private:
  void Separator();
  void FlushIfFull();

  std::unique_ptr<AtomicFile> file_;
  std::size_t num_columns_ = 0;
  std::size_t fields_in_row_ = 0;
  std::string buffer_;
};

// A whole table whose first column is text (each row's label, e.g. an image name) and the others
// numbers, written through CsvWriter: each row a label and columns.size() - 1 numbers. Plain rows,
// so a library that io does not link (stereo/) can hand over its table.
using LabelledRow = std::pair<std::string, std::vector<double>>;
void WriteLabelledCsv(const std::string& path, std::vector<std::string> columns,
                      const std::vector<LabelledRow>& rows);

}  // namespace omni::io
