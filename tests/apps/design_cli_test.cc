// Runs the real `omnistereo design` on bad configs: non-zero exit, one stderr line naming the file
// and the field, and no output file left behind. And once on the good sample config.
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/cli_test_util.h"

#ifndef OMNI_SAMPLE_CONFIGS
#error "OMNI_SAMPLE_CONFIGS must name sample_configs/"
#endif

namespace {

namespace fs = std::filesystem;

using omni::testing::ReadText;

class DesignCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("omni_design_cli_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    good_ = ReadText(fs::path(OMNI_SAMPLE_CONFIGS) / "big_rig_design.yaml");
    ASSERT_FALSE(good_.empty());
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs the command; returns the exit status, fills stderr and stdout.
  int Run(const std::string& config_path, std::string* err, std::string* out = nullptr) {
    return omni::testing::RunOmnistereo(
        "design --config='" + config_path + "' --out='" + (dir_ / "model.yaml").string() +
            "' --curves_out='" + (dir_ / "curves").string() + "'",
        dir_ / "stderr.txt", err, dir_ / "stdout.txt", out);
  }
  std::string Write(const std::string& text) {
    const fs::path p = dir_ / "design.yaml";
    std::ofstream(p) << text;
    return p.string();
  }
  // The good config with one line's value replaced.
  std::string WithReplaced(const std::string& from, const std::string& to) {
    const std::string text = std::regex_replace(good_, std::regex(from), to,
                                                std::regex_constants::format_first_only);
    EXPECT_NE(text, good_) << "pattern not found: " << from;
    return Write(text);
  }
  void ExpectRejected(const std::string& config, const std::string& field) {
    std::string err;
    EXPECT_NE(Run(config, &err), 0);
    EXPECT_NE(err.find(config), std::string::npos) << err;
    EXPECT_NE(err.find(field), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(dir_ / "model.yaml"));
    EXPECT_FALSE(fs::exists(dir_ / "curves"));
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name == "design.yaml" || name == "stderr.txt" || name == "stdout.txt") << name;
    }
  }

  fs::path dir_;
  std::string good_;
};

TEST_F(DesignCli, K1AtMostTwo) {
  ExpectRejected(WithReplaced("k1: 3\\.0", "k1: 2.0"), "search_box.lower.k1");
}
TEST_F(DesignCli, C1NotPositive) {
  ExpectRejected(WithReplaced("c1: 120\\.0", "c1: -1.0"), "search_box.lower.c1");
}
TEST_F(DesignCli, RsysNotPositive) {
  ExpectRejected(WithReplaced("r_sys: 37\\.0", "r_sys: 0.0"), "search_box.lower.r_sys");
}
TEST_F(DesignCli, LowerAboveUpper) {
  ExpectRejected(WithReplaced("d: 150\\.0", "d: 600.0"), "search_box.lower.d");
}
TEST_F(DesignCli, NonFiniteNumber) {
  ExpectRejected(WithReplaced("h_sys_max: 150\\.0", "h_sys_max: .nan"), "constraints.h_sys_max");
}
TEST_F(DesignCli, MissingKey) {
  ExpectRejected(WithReplaced("r_cam: 7\\.0", "r_cam_mm: 7.0"), "r_cam");
}
TEST_F(DesignCli, MissingFile) {
  ExpectRejected((dir_ / "no_such_design.yaml").string(), "no_such_design.yaml");
}
TEST_F(DesignCli, MalformedYaml) {
  ExpectRejected(Write("format: omnistereo-design/1\nsearch_box: {lower: [1, 2\n"), "line");
}
TEST_F(DesignCli, UnknownVersion) {
  ExpectRejected(
      WithReplaced("\nformat: omnistereo-design/1", "\nformat: omnistereo-design/2"), "format");
}

TEST_F(DesignCli, SampleConfigWritesModelAndCurves) {
  std::string err, out;
  ASSERT_EQ(Run((fs::path(OMNI_SAMPLE_CONFIGS) / "big_rig_design.yaml").string(), &err, &out), 0)
      << err;
  EXPECT_NE(out.find("131.607"), std::string::npos) << out;
  const std::string model = ReadText(dir_ / "model.yaml");
  EXPECT_NE(model.find("format: omnistereo-model/1"), std::string::npos);
  EXPECT_NE(model.find("kind: ideal"), std::string::npos);
  for (const char* csv : {"rsys_vs_k.csv", "baseline_vs_k1.csv", "resolution_vs_elevation.csv"}) {
    EXPECT_TRUE(fs::exists(dir_ / "curves" / csv)) << csv;
  }
}

}  // namespace
