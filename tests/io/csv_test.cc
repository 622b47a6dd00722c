// CSV point lists (docs/design.md, Conventions): columns by name, exact numbers, one-line errors with the line
// and column, streaming across buffer boundaries, and writes that leave nothing half-written.
#include "io/csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <limits>
#include <random>

#include "tests/io/io_test_util.h"

namespace omni::io {
namespace {

using omni::testing::ReadText;
using omni::testing::ScratchDir;
using omni::testing::WriteText;

const std::vector<std::string> kPointColumns = {"x_mm", "y_mm", "z_mm"};

std::uint64_t Bits(double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof(bits));
  return bits;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

// Reads every row of the required columns.
std::vector<std::vector<double>> ReadAll(const std::string& path,
                                         const std::vector<std::string>& columns) {
  CsvReader reader(path, columns);
  std::vector<std::vector<double>> rows;
  std::vector<double> row;
  while (reader.ReadRow(&row)) rows.push_back(row);
  return rows;
}

TEST(CsvTest, WriteThenReadIsBitExact) {
  ScratchDir dir;
  std::mt19937_64 rng(3);
  std::vector<std::vector<double>> rows;
  for (int i = 0; i < 2000; ++i) {
    std::uint64_t bits[3] = {rng(), rng(), rng()};  // any finite double, subnormals included
    std::vector<double> row(3);
    for (int j = 0; j < 3; ++j) {
      std::memcpy(&row[j], &bits[j], sizeof(double));
      if (!std::isfinite(row[j])) row[j] = std::ldexp(static_cast<double>(bits[j] >> 11), -1074);
    }
    rows.push_back(row);
  }
  rows.push_back({-0.0, 0.1 + 0.2, std::numeric_limits<double>::denorm_min()});
  rows.push_back({std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::max()});
  {
    CsvWriter writer(dir / "points.csv", kPointColumns);
    for (const auto& row : rows) writer.WriteRow(row);
    writer.Commit();
  }
  const auto back = ReadAll(dir / "points.csv", kPointColumns);
  ASSERT_EQ(back.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (int j = 0; j < 3; ++j) {
      EXPECT_EQ(Bits(back[i][j]), Bits(rows[i][j])) << "row " << i << " col " << j;
    }
  }
  EXPECT_EQ(ReadText(dir / "points.csv").rfind("x_mm,y_mm,z_mm\n", 0), 0u);
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"points.csv"});
}

TEST(CsvTest, NanIsReadBack) {
  ScratchDir dir;
  {
    CsvWriter writer(dir / "p.csv", {"u1", "v1", "valid1"});
    writer.WriteRow({std::nan(""), std::nan(""), 0});
    writer.Commit();
  }
  const auto rows = ReadAll(dir / "p.csv", {"valid1", "u1"});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0][0], 0.0);
  EXPECT_TRUE(std::isnan(rows[0][1]));
}

TEST(CsvTest, FindsColumnsByNameInAnyOrderAndSkipsExtraColumns) {
  ScratchDir dir;
  WriteText(dir / "p.csv",
            "\xEF\xBB\xBF" "id, z_mm ,name,x_mm,y_mm\r\n"
            "1, 3.5 ,first,1,+2\r\n"
            "\n"
            "2,-1e-3,second point,4,5.25");  // no final newline
  CsvReader reader(dir / "p.csv", kPointColumns);
  EXPECT_EQ(reader.header(), (std::vector<std::string>{"id", "z_mm", "name", "x_mm", "y_mm"}));
  std::vector<double> row;
  ASSERT_TRUE(reader.ReadRow(&row));
  EXPECT_EQ(row, (std::vector<double>{1, 2, 3.5}));
  EXPECT_EQ(reader.line(), 2);
  EXPECT_EQ(reader.Field(reader.ColumnIndex("name")), "first");
  ASSERT_TRUE(reader.ReadRow(&row));
  EXPECT_EQ(row, (std::vector<double>{4, 5.25, -1e-3}));
  EXPECT_EQ(reader.line(), 4);
  EXPECT_EQ(reader.Field(reader.ColumnIndex("name")), "second point");
  EXPECT_FALSE(reader.ReadRow(&row));
  EXPECT_EQ(reader.ColumnIndex("w_mm"), -1);
}

TEST(CsvTest, BadNumberNamesFileLineAndColumn) {
  ScratchDir dir;
  const std::string path = dir / "p.csv";
  WriteText(path, "x_mm,y_mm,z_mm\n1,2,3\n4,abc,6\n");
  EXPECT_EQ(ErrorOf([&] { ReadAll(path, kPointColumns); }),
            path + ": line 3: column 'y_mm': expected a number, got 'abc'");
  WriteText(path, "x_mm,y_mm,z_mm\n1,,3\n");
  EXPECT_EQ(ErrorOf([&] { ReadAll(path, kPointColumns); }),
            path + ": line 2: column 'y_mm': expected a number, got ''");
  WriteText(path, "x_mm,y_mm,z_mm\n1,2,3mm\n");
  EXPECT_EQ(ErrorOf([&] { ReadAll(path, kPointColumns); }),
            path + ": line 2: column 'z_mm': expected a number, got '3mm'");
}

TEST(CsvTest, HeaderProblemsNameFileAndColumn) {
  ScratchDir dir;
  const std::string path = dir / "p.csv";
  WriteText(path, "x_mm,y_mm\n1,2\n");
  EXPECT_EQ(ErrorOf([&] { CsvReader reader(path, kPointColumns); }),
            path + ": line 1: column 'z_mm': expected in the header, got 'x_mm,y_mm'");
  WriteText(path, "x_mm,y_mm,x_mm\n");
  EXPECT_EQ(ErrorOf([&] { CsvReader reader(path, kPointColumns); }),
            path + ": line 1: column 'x_mm': expected once in the header, got twice");
  WriteText(path, "\n\n");
  EXPECT_EQ(ErrorOf([&] { CsvReader reader(path, kPointColumns); })
                .rfind(path + ": line 2: expected a header row naming the columns (x_mm,y_mm,z_mm)", 0),
            0u);
  EXPECT_EQ(ErrorOf([&] { CsvReader reader(dir / "none.csv", kPointColumns); }),
            dir / "none.csv" + ": expected a readable CSV file, got no such file");
}

// Found by scripts/fuzz.sh (fuzz_pixels_csv ran out of file descriptors): a reader whose
// header is rejected must close its file. The oracle is the process's own list of open files.
TEST(CsvTest, RejectedHeaderClosesTheFile) {
  ScratchDir dir;
  const std::string path = dir / "p.csv";
  const auto open_files = [] {
    return std::distance(std::filesystem::directory_iterator("/proc/self/fd"),
                         std::filesystem::directory_iterator{});
  };
  for (const char* text : {"x_mm,y_mm\n1,2\n", "x_mm,y_mm,x_mm\n", "\n\n"}) {
    WriteText(path, text);
    const auto before = open_files();
    for (int i = 0; i < 50; ++i) {
      EXPECT_NE(ErrorOf([&] { CsvReader reader(path, kPointColumns); }), "no error");
    }
    EXPECT_EQ(open_files(), before) << text;
  }
}

TEST(CsvTest, WrongFieldCountNamesTheLine) {
  ScratchDir dir;
  const std::string path = dir / "p.csv";
  WriteText(path, "x_mm,y_mm,z_mm\n1,2,3\n1,2,3,\n");
  EXPECT_EQ(ErrorOf([&] { ReadAll(path, kPointColumns); }),
            path + ": line 3: expected 3 comma-separated fields as in the header, got 4");
  WriteText(path, "x_mm,y_mm,z_mm\n1,2\n");
  EXPECT_EQ(ErrorOf([&] { ReadAll(path, kPointColumns); }),
            path + ": line 2: expected 3 comma-separated fields as in the header, got 2");
}

// Rows cross the reader's 1 MiB buffer many times; one line is longer than the buffer.
TEST(CsvTest, StreamsAcrossBufferBoundariesAndLongLines) {
  ScratchDir dir;
  const std::string path = dir / "many.csv";
  constexpr int kRows = 200000;
  const auto value = [](int i, int j) { return (i * 3 + j) * 0.001 - 17.0 / (j + 3); };
  const std::string long_text(3 << 20, 'a');
  {
    CsvWriter writer(path, {"note", "x_mm", "y_mm", "z_mm"});
    for (int i = 0; i < kRows; ++i) {
      writer.Add(i == kRows / 2 ? std::string_view(long_text) : std::string_view("n"));
      for (int j = 0; j < 3; ++j) writer.Add(value(i, j));
      writer.EndRow();
    }
    writer.Commit();
  }
  CsvReader reader(path, kPointColumns);
  std::vector<double> row;
  int count = 0;
  while (reader.ReadRow(&row)) {
    for (int j = 0; j < 3; ++j) ASSERT_EQ(row[j], value(count, j)) << "row " << count;
    if (count == kRows / 2) {
      EXPECT_EQ(reader.Field(0).size(), long_text.size());
    }
    ++count;
  }
  EXPECT_EQ(count, kRows);
  EXPECT_EQ(reader.line(), kRows + 1);
}

TEST(CsvTest, WriterWithoutCommitLeavesNothingAndKeepsTheOldFile) {
  ScratchDir dir;
  {
    CsvWriter writer(dir / "new.csv", kPointColumns);
    writer.WriteRow({1, 2, 3});
  }  // e.g. an exception unwound past the writer
  EXPECT_TRUE(dir.Entries().empty());

  WriteText(dir / "old.csv", "x_mm,y_mm,z_mm\n7,8,9\n");
  {
    CsvWriter writer(dir / "old.csv", kPointColumns);
    for (int i = 0; i < 300000; ++i) writer.WriteRow({1.5, 2.5, 3.5});  // flushes to disk
  }
  EXPECT_EQ(ReadText(dir / "old.csv"), "x_mm,y_mm,z_mm\n7,8,9\n");
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"old.csv"});

  {
    CsvWriter writer(dir / "old.csv", kPointColumns);
    writer.WriteRow({1, 2, 3});
    writer.Commit();
  }
  EXPECT_EQ(ReadText(dir / "old.csv"), "x_mm,y_mm,z_mm\n1,2,3\n");
}

TEST(CsvTest, WriterErrors) {
  ScratchDir dir;
  const std::string path = dir / "no/folder/p.csv";
  try {
    CsvWriter writer(path, kPointColumns);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_TRUE(dir.Entries().empty());

  CsvWriter writer(dir / "p.csv", kPointColumns);
  EXPECT_THROW(writer.WriteRow({1, 2}), std::invalid_argument);
  EXPECT_THROW(writer.Add(std::string_view("a,b")), std::invalid_argument);
  EXPECT_THROW(CsvWriter(dir / "q.csv", {"x,y"}), std::invalid_argument);
}

// A labelled table (text first column, e.g. `triangulate`'s image names) reads back by column name.
TEST(CsvTest, LabelledRowsReadBackWithTheirLabels) {
  ScratchDir dir;
  WriteLabelledCsv(dir / "t.csv", {"image", "x_mm", "y_mm"},
                   {{"0001.jpg", {1.5, -2}}, {"0002.jpg", {0.1 + 0.2, 3}}});
  CsvReader in(dir / "t.csv", {"x_mm", "y_mm"});
  std::vector<double> v;
  ASSERT_TRUE(in.ReadRow(&v));
  EXPECT_EQ(in.Field(0), "0001.jpg");
  EXPECT_EQ(v, (std::vector<double>{1.5, -2}));
  ASSERT_TRUE(in.ReadRow(&v));
  EXPECT_EQ(in.Field(0), "0002.jpg");
  EXPECT_EQ(v, (std::vector<double>{0.1 + 0.2, 3}));
  EXPECT_FALSE(in.ReadRow(&v));
  // A row of the wrong length is a programmer error, and nothing is left behind.
  EXPECT_THROW(WriteLabelledCsv(dir / "u.csv", {"image", "x_mm"}, {{"a", {1, 2}}}),
               std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir / "u.csv"));
}

}  // namespace
}  // namespace omni::io
