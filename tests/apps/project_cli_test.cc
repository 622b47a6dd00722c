// Runs the real `omnistereo project` / `omnistereo unproject`: outputs equal the library's
// RigModel row by row; bad input ends with exit code 2, one stderr line naming the file and the
// field, and no output file (an existing one untouched).
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "io/csv.h"
#include "io/model_file.h"
#include "model/rig_model.h"
#include "tests/model/rig_test_util.h"

#include "tests/cli_test_util.h"

namespace omni {
namespace {

namespace fs = std::filesystem;

using testing::ReadText;

class ProjectCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("omni_project_cli_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::mt19937 rng(42);
    model_path_ = (dir_ / "model.yaml").string();
    io::WriteModelFile(model_path_, testing::MisalignedBigRig(&rng, 1.0, 1.0, true));
  }
  void TearDown() override { fs::remove_all(dir_); }

  int Run(const std::string& args, std::string* err) {
    return testing::RunOmnistereo(args, dir_ / "stderr.txt", err);
  }
  std::string Write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  void ExpectRejected(const std::string& args, const std::string& file, const std::string& field,
                      const fs::path& out) {
    std::string err;
    EXPECT_EQ(Run(args, &err), 2) << args;
    EXPECT_NE(err.find(file), std::string::npos) << err;
    EXPECT_NE(err.find(field), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(out)) << args;
    for (const auto& entry : fs::directory_iterator(dir_)) {  // no temporary file left
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name == "model.yaml" || name == "stderr.txt" || name.find(".csv") != std::string::npos)
          << name;
    }
  }

  fs::path dir_;
  std::string model_path_;
};

TEST_F(ProjectCli, ProjectEqualsLibrary) {
  const RigModel model(io::ReadModelFile(model_path_));
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::ostringstream text;
  text << "id,z_mm,x_mm,y_mm\n";  // columns in any order, extra columns skipped
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 3000; ++i) {
    const double az = 2 * M_PI * u(rng), el = -1.2 + 2.4 * u(rng), r = 200 + 5000 * u(rng);
    points.emplace_back(r * std::cos(el) * std::cos(az), r * std::cos(el) * std::sin(az),
                        60 + r * std::sin(el));
    text << i << "," << io::FormatDouble(points.back().z()) << ","
         << io::FormatDouble(points.back().x()) << "," << io::FormatDouble(points.back().y())
         << "\n";
  }
  const std::string in = Write("points.csv", text.str());
  const std::string out = (dir_ / "pixels.csv").string();
  std::string err;
  ASSERT_EQ(Run("project --model='" + model_path_ + "' --points='" + in + "' --out='" + out + "'",
                &err),
            0)
      << err;
  io::CsvReader reader(out, {"u1", "v1", "valid1", "u2", "v2", "valid2"});
  std::vector<double> row;
  size_t i = 0;
  int valid[3] = {0, 0, 0};
  while (reader.ReadRow(&row)) {
    ASSERT_LT(i, points.size());
    for (int m : {1, 2}) {
      const auto px = model.Project(points[i], m == 1 ? Mirror::kOne : Mirror::kTwo);
      const double* r = &row[3 * (m - 1)];
      ASSERT_EQ(r[2], px ? 1.0 : 0.0) << "row " << i;
      if (px) {
        EXPECT_EQ(r[0], px->x());
        EXPECT_EQ(r[1], px->y());
        ++valid[m];
      } else {
        EXPECT_TRUE(std::isnan(r[0]) && std::isnan(r[1]));
      }
    }
    ++i;
  }
  EXPECT_EQ(i, points.size());
  EXPECT_GT(valid[1], 300);
  EXPECT_GT(valid[2], 300);
}

TEST_F(ProjectCli, UnprojectEqualsLibrary) {
  const RigModel model(io::ReadModelFile(model_path_));
  std::ostringstream text;
  text << "u,v\n";
  std::vector<Eigen::Vector2d> pixels;
  for (double v = 0.5; v < 960; v += 13.7) {
    for (double u = 0.5; u < 1280; u += 11.3) {
      pixels.emplace_back(u, v);
      text << io::FormatDouble(u) << "," << io::FormatDouble(v) << "\n";
    }
  }
  const std::string in = Write("pixels.csv", text.str());
  const std::string out = (dir_ / "rays.csv").string();
  std::string err;
  ASSERT_EQ(Run("unproject --model='" + model_path_ + "' --pixels='" + in + "' --out='" + out + "'",
                &err),
            0)
      << err;
  io::CsvReader reader(out, {"mirror", "ox", "oy", "oz", "dx", "dy", "dz", "valid"});
  std::vector<double> row;
  size_t i = 0;
  int count[3] = {0, 0, 0};
  while (reader.ReadRow(&row)) {
    ASSERT_LT(i, pixels.size());
    const auto ray = model.Unproject(pixels[i]);
    ASSERT_EQ(row[7], ray ? 1.0 : 0.0) << "row " << i;
    if (ray) {
      EXPECT_EQ(row[0], MirrorIndex(ray->mirror));
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(row[1 + k], ray->ray.origin(k));
        EXPECT_EQ(row[4 + k], ray->ray.direction(k));
      }
      ++count[MirrorIndex(ray->mirror)];
    } else {
      EXPECT_EQ(row[0], 0.0);
      for (int k = 1; k < 7; ++k) EXPECT_TRUE(std::isnan(row[k]));
      ++count[0];
    }
    ++i;
  }
  EXPECT_EQ(i, pixels.size());
  EXPECT_GT(count[0], 100);
  EXPECT_GT(count[1], 1000);
  EXPECT_GT(count[2], 300);
}

TEST_F(ProjectCli, BadInputIsRejectedWithoutOutput) {
  const fs::path out = dir_ / "out.csv";
  const std::string o = " --out='" + out.string() + "'";
  const std::string m = " --model='" + model_path_ + "'";
  const std::string bad_number = Write("bad_number.csv", "x_mm,y_mm,z_mm\n1,2,3\n4,abc,6\n");
  ExpectRejected("project" + m + " --points='" + bad_number + "'" + o, bad_number, "y_mm", out);
  const std::string nan_value = Write("nan_value.csv", "x_mm,y_mm,z_mm\n1,2,3\n4,5,nan\n");
  ExpectRejected("project" + m + " --points='" + nan_value + "'" + o, nan_value, "z_mm", out);
  const std::string no_column = Write("no_column.csv", "x_mm,y_mm\n1,2\n");
  ExpectRejected("project" + m + " --points='" + no_column + "'" + o, no_column, "z_mm", out);
  const std::string bad_pixel = Write("bad_pixel.csv", "u,v\n1,2\n3,\n");
  ExpectRejected("unproject" + m + " --pixels='" + bad_pixel + "'" + o, bad_pixel, "'v'", out);
  const std::string missing = (dir_ / "missing.csv").string();
  ExpectRejected("unproject" + m + " --pixels='" + missing + "'" + o, missing, "missing", out);
  const std::string bad_model = Write("bad_model.csv", "format: omnistereo-model/1\n");
  ExpectRejected("project --model='" + bad_model + "' --points='" + bad_number + "'" + o,
                 bad_model, "bad_model", out);
  ExpectRejected("project --points='" + bad_number + "'" + o, "--model", "model", out);

  // An existing output stays untouched when the input is bad.
  std::ofstream(out) << "precious\n";
  std::string err;
  EXPECT_EQ(Run("project" + m + " --points='" + bad_number + "'" + o, &err), 2);
  EXPECT_EQ(ReadText(out), "precious\n");
}

// A model whose mirror 1 names a measured profile (profile_from:): a good scan reads and projects;
// a bad one (radii unsorted, a gap wider than the stated bound, a sag beyond the profile's
// bound) ends in exit 2 with one line naming the scan and its line, and no output.
TEST_F(ProjectCli, AModelsBadProfileScanIsRejectedWithoutOutput) {
  std::string text = ReadText(model_path_);
  const size_t at = text.find('\n', text.find("  lip: {color: blue")) + 1;
  text.insert(at, "  profile_from: scan.csv\n  profile_accuracy_mm: 0.001\n  profile_max_gap_mm: 1.0\n");
  const std::string model = Write("scan_model.yaml", text);
  const std::string points = Write("points.csv", "x_mm,y_mm,z_mm\n900,300,200\n");
  const fs::path out = dir_ / "out.csv";
  const std::string args =
      "project --model='" + model + "' --points='" + points + "' --out='" + out.string() + "'";
  std::string good = "r_mm,sag_mm\n";
  for (int i = 0; i <= 148; ++i) good += std::to_string(i * 0.25) + "," + std::to_string(1e-6 * i) + "\n";
  Write("scan.csv", good);
  std::string err;
  ASSERT_EQ(Run(args, &err), 0) << err;
  ASSERT_TRUE(fs::exists(out));
  fs::remove(out);
  for (const auto& [scan, expected] : std::vector<std::pair<std::string, std::string>>{
           {"r_mm,sag_mm\n20,0\n19,0\n", "scan.csv: line 3: r_mm 19 after 20"},
           {good.substr(0, good.find("\n30.250000")) + "\n", "expected gaps of at most 1 mm"},
           {"r_mm,sag_mm\n20,0.2\n", "scan.csv: line 2: sag_mm 0.2: expected a departure"}}) {
    Write("scan.csv", scan);
    EXPECT_EQ(Run(args, &err), 2) << scan;
    EXPECT_NE(err.find(expected), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(out));
  }
}

}  // namespace
}  // namespace omni
