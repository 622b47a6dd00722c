// Session and detections files: what is written reads back; every malformed input is one
// InputError naming the file and the key.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "io/detections_file.h"
#include "io/file_util.h"
#include "io/session_file.h"

namespace omni::io {
namespace {

namespace fs = std::filesystem;

class SessionFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("omni_session_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "images");
    for (const char* name : {"0002.png", "0001.png", "0010.png"}) {
      std::ofstream(dir_ / "images" / name) << "x";
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& text) {
    const std::string path = (dir_ / "session.yaml").string();
    std::ofstream(path) << text;
    return path;
  }

  // The message of the InputError that reading `text` throws ("" if none).
  std::string ErrorOf(const std::string& text) {
    try {
      ReadSessionFile(Write(text));
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

constexpr char kGood[] = R"(format: omnistereo-session/1
model: ../rig.yaml
images: [images/*.png]
targets:
  - {type: chessboard, rows: 6, cols: 8, square: 40.0}
  - {type: apriltag_grid, family: tag36h11, rows: 5, cols: 5, tag_size: 30.0, spacing: 0.3, first_id: 0}
  - {type: kalibr_aprilgrid, rows: 2, cols: 3, tag_size: 45.0, spacing: 0.25, first_id: 30}
estimate: [camera, mirror1_pose]
priors: {mirror1_shape: {sigma_c: 0.05, sigma_k: 0.01}}
consider: {dist_p1: 0.0004, dist_p2: 0}
profile: free
profile_sigma_mm: 0.003
noncentral: free
solver: {max_iterations: 50, loss: cauchy, outlier_px: 2.5}
)";

TEST_F(SessionFileTest, ReadsTheExampleAndExpandsGlobsSorted) {
  const Session s = ReadSessionFile(Write(kGood));
  EXPECT_EQ(s.model_path, (dir_.parent_path() / "rig.yaml").string());
  ASSERT_EQ(s.images.size(), 3u);
  EXPECT_EQ(fs::path(s.images[0]).filename(), "0001.png");
  EXPECT_EQ(fs::path(s.images[2]).filename(), "0010.png");
  ASSERT_EQ(s.targets.size(), 3u);
  EXPECT_EQ(s.targets[0].type, TargetType::kChessboard);
  EXPECT_EQ(s.targets[1].type, TargetType::kAprilTagGrid);
  EXPECT_EQ(s.targets[2].type, TargetType::kKalibrAprilGrid);
  EXPECT_DOUBLE_EQ(s.targets[2].spacing, 0.25);
  EXPECT_EQ(s.targets[2].first_id, 30);
  EXPECT_EQ(s.estimate, (std::vector<std::string>{"camera", "mirror1_pose"}));
  EXPECT_DOUBLE_EQ(s.priors.at("mirror1_shape").sigma_k, 0.01);
  ASSERT_TRUE(s.consider.has_value());
  EXPECT_EQ(s.consider->size(), 2u);
  EXPECT_DOUBLE_EQ(s.consider->at("dist_p1"), 0.0004);
  EXPECT_DOUBLE_EQ(s.consider->at("dist_p2"), 0.0);
  EXPECT_EQ(s.solver.loss, "cauchy");
  EXPECT_EQ(s.solver.max_iterations, 50);
  EXPECT_DOUBLE_EQ(s.solver.outlier_px, 2.5);
}

TEST_F(SessionFileTest, WrittenTextReadsBackTheSame) {
  const Session s = ReadSessionFile(Write(kGood));
  const Session t = ReadSessionFile(Write(SessionText(s, dir_.string())));
  EXPECT_EQ(t.model_path, s.model_path);
  EXPECT_EQ(t.images, s.images);
  ASSERT_EQ(t.targets.size(), s.targets.size());
  for (size_t i = 0; i < s.targets.size(); ++i) {
    EXPECT_EQ(t.targets[i].type, s.targets[i].type);
    EXPECT_EQ(t.targets[i].rows, s.targets[i].rows);
    EXPECT_EQ(t.targets[i].tag_size_mm, s.targets[i].tag_size_mm);
    EXPECT_EQ(t.targets[i].square_mm, s.targets[i].square_mm);
  }
  EXPECT_EQ(t.estimate, s.estimate);
  EXPECT_EQ(t.priors.size(), 1u);
  EXPECT_EQ(t.consider, s.consider);
  EXPECT_EQ(s.profile, "free");
  EXPECT_EQ(t.profile, "free");
  EXPECT_EQ(t.profile_sigma_mm, 0.003);
  EXPECT_EQ(s.noncentral, "free");
  EXPECT_EQ(t.noncentral, "free");
  EXPECT_EQ(t.solver.loss, "cauchy");
}

// `targets: []` is a lips-only session (detect checks the intrinsics from the lips alone); it is
// written back as such. A missing or scalar `targets` is still an error naming the key.
TEST_F(SessionFileTest, LipsOnlySessionHasNoTargets) {
  std::string text = kGood;
  const auto from = text.find("targets:\n"), to = text.find("estimate:");
  ASSERT_NE(from, std::string::npos);
  text.replace(from, to - from, "targets: []\n");
  const Session s = ReadSessionFile(Write(text));
  EXPECT_TRUE(s.targets.empty());
  EXPECT_TRUE(s.use_lips);
  const std::string written = SessionText(s, dir_.string());
  EXPECT_NE(written.find("targets: []\n"), std::string::npos) << written;
  EXPECT_TRUE(ReadSessionFile(Write(written)).targets.empty());
  for (const char* bad : {"", "targets: chessboard\n"}) {
    std::string t = text;
    t.replace(t.find("targets: []\n"), 12, bad);
    const std::string error = ErrorOf(t);
    EXPECT_NE(error.find("session.yaml: targets: expected a list of targets ([] for a lips-only "
                         "session)"),
              std::string::npos)
        << error;
  }
}

// A session for calibrate / report with --detections needs no image list (what `init` and
// hand-written sessions may leave out); detect then says it needs the images.
TEST_F(SessionFileTest, ImagesMayBeLeftOut) {
  std::string text = kGood;
  text.replace(text.find("images: [images/*.png]\n"), 23, "");
  const Session s = ReadSessionFile(Write(text));
  EXPECT_TRUE(s.images.empty());
  EXPECT_EQ(s.targets.size(), 3u);
  // Written without images, read back without them.
  const std::string written = SessionText(s, dir_.string());
  EXPECT_EQ(written.find("images:"), std::string::npos) << written;
  EXPECT_TRUE(ReadSessionFile(Write(written)).images.empty());
  text = kGood;
  text.replace(text.find("images: [images/*.png]\n"), 23, "images:\n");
  EXPECT_TRUE(ReadSessionFile(Write(text)).images.empty());
}

// Targets as `init --targets` takes them: a list or one entry; errors name the entry's key.
TEST(TargetListTest, ParsesSessionEntries) {
  const auto list = ParseTargetList(
      "[{type: chessboard, rows: 5, cols: 6, square: 35}, {type: kalibr_aprilgrid, rows: 2, "
      "cols: 3, tag_size: 65, spacing: 0.3, first_id: 50}]",
      "--targets");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[1].type, TargetType::kKalibrAprilGrid);
  EXPECT_EQ(list[1].first_id, 50);
  EXPECT_EQ(TargetEntryText(list[0]), "{type: chessboard, rows: 5, cols: 6, square: 35}");
  EXPECT_EQ(ParseTargetList("{type: chessboard, rows: 5, cols: 6, square: 35}", "x").size(), 1u);
  try {
    ParseTargetList("[{type: chessboard, rows: 5, cols: 6}]", "--targets");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--targets: [0].square"), std::string::npos) << e.what();
  }
}

TEST_F(SessionFileTest, MalformedInputNamesTheKey) {
  struct Case {
    std::string from, to, key;
  };
  const std::vector<Case> cases = {
      {"omnistereo-session/1", "omnistereo-session/2", "format"},
      {"model: ../rig.yaml\n", "", "model"},
      {"images/*.png", "nothing/*.png", "images[0]"},
      {"type: chessboard", "type: circles", "targets[0].type"},
      {"rows: 6", "rows: 1", "targets[0].rows"},
      {"square: 40.0", "square: -4", "targets[0].square"},
      {"tag_size: 30.0", "tag_size: x", "targets[1].tag_size"},
      {"family: tag36h11", "family: tag25h9", "targets[1].family"},
      {"first_id: 30", "first_id: 585", "targets[2]"},
      {"[camera, mirror1_pose]", "[camera, lens]", "estimate[1]"},
      {"[camera, mirror1_pose]", "[camera, camera]", "estimate[1]"},
      {"[camera, mirror1_pose]", "camera", "estimate"},  // ([] scores the model: valid)
      {"sigma_k: 0.01", "sigma_k: 0", "priors.mirror1_shape.sigma_k"},
      {"loss: cauchy", "loss: l1", "solver.loss"},
      {"dist_p2: 0}", "dist_p2: -1e-4}", "consider.dist_p2"},
      {"dist_p2: 0}", "dist_k1: 1e-4}", "consider.dist_k1"},
      {"{dist_p1: 0.0004, dist_p2: 0}", "[dist_p1]", "consider"},
      {"profile: free", "profile: maybe", "profile"},
      {"profile_sigma_mm: 0.003", "profile_sigma_mm: 0", "profile_sigma_mm"},
      {"noncentral: free", "noncentral: maybe", "noncentral"},
      // Found by scripts/fuzz.sh: a key that is not a name (was a yaml-cpp bad-conversion error).
      {"{dist_p1: 0.0004, dist_p2: 0}", "{[dist_p1]: 0.0004}", "consider"},
  };
  for (const Case& c : cases) {
    std::string text = kGood;
    const auto at = text.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    text.replace(at, c.from.size(), c.to);
    const std::string error = ErrorOf(text);
    EXPECT_NE(error.find("session.yaml: " + c.key + ":"), std::string::npos)
        << c.key << " -> " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  EXPECT_NE(ErrorOf("format: [\n").find("line"), std::string::npos);
}

TEST(DetectionsFileTest, RoundTripsExactly) {
  Observations d;
  d.session = "session.yaml";
  ImageObservations image;
  image.file = "images/0001.png";
  image.width = 1280;
  image.height = 960;
  image.corners.push_back({0, 12, Mirror::kOne, Eigen::Vector2d(523.1123456789, 301.887)});
  image.corners.push_back({2, 4 * 7 + 3, Mirror::kTwo, Eigen::Vector2d(611.405, 1.0 / 3.0)});
  LipEdgeObservation lip;
  lip.mirror = Mirror::kOne;
  lip.edge = BandEdge::kOuter;
  lip.circle = LipCircle::kOuter;
  lip.path = LipPath::kDirect;
  lip.points = {Eigen::Vector2d(233.1, 480.2), Eigen::Vector2d(233.4, 470.9)};
  image.lips.push_back(lip);
  d.images.push_back(image);
  d.images.push_back(ImageObservations{"images/0002.png", 1280, 960, {}, {}});

  const std::string path =
      (fs::temp_directory_path() / "omni_detections_roundtrip.yaml").string();
  WriteDetectionsFile(path, d);
  const Observations r = ReadDetectionsFile(path);
  fs::remove(path);
  EXPECT_EQ(r.session, d.session);
  ASSERT_EQ(r.images.size(), 2u);
  ASSERT_EQ(r.images[0].corners.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(r.images[0].corners[i].target, d.images[0].corners[i].target);
    EXPECT_EQ(r.images[0].corners[i].id, d.images[0].corners[i].id);
    EXPECT_EQ(r.images[0].corners[i].mirror, d.images[0].corners[i].mirror);
    EXPECT_EQ(r.images[0].corners[i].pixel, d.images[0].corners[i].pixel);  // bit for bit
  }
  ASSERT_EQ(r.images[0].lips.size(), 1u);
  EXPECT_TRUE(r.images[0].lips[0].path == LipPath::kDirect);
  EXPECT_TRUE(r.images[0].lips[0].circle == LipCircle::kOuter);
  EXPECT_TRUE(r.images[0].lips[0].edge == BandEdge::kOuter);
  EXPECT_EQ(r.images[0].lips[0].points, lip.points);
  EXPECT_TRUE(r.images[1].corners.empty());
}

TEST(DetectionsFileTest, BadRowsNameTheKey) {
  const std::string path = (fs::temp_directory_path() / "omni_detections_bad.yaml").string();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"[0, 12, 3, 1.0, 2.0]", "images[0].corners[0][2]"},
      {"[0, 12, 1, 1.0]", "images[0].corners[0]"},
      {"[0, -1, 1, 1.0, 2.0]", "images[0].corners[0][1]"},
      {"[0, 12, 1, u, 2.0]", "images[0].corners[0][3]"},
      // Beyond int's range or not whole (the range check came after a cast that is undefined
      // behaviour for such a value).
      {"[0, 1e30, 1, 1.0, 2.0]", "images[0].corners[0][1]"},
      {"[3000000000, 12, 1, 1.0, 2.0]", "images[0].corners[0][0]"},
      {"[0, 12.5, 1, 1.0, 2.0]", "images[0].corners[0][1]"},
  };
  for (const auto& [row, key] : cases) {
    std::ofstream(path) << "format: omnistereo-detections/1\nimages:\n  - file: a.png\n"
                           "    width: 10\n    height: 10\n    corners:\n      - "
                        << row << "\n";
    try {
      ReadDetectionsFile(path);
      ADD_FAILURE() << "accepted " << row;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path + ": " + key + ":"), std::string::npos)
          << e.what();
    }
  }
  fs::remove(path);
}

// A lip edge's labels are checked when read: names as the format has them, and a path that
// images the edge's own mirror's lip. Unlabelled edges (the format example's) are read as such.
TEST(DetectionsFileTest, LipLabelsAreCheckedWhenRead) {
  const std::string path = (fs::temp_directory_path() / "omni_detections_lips.yaml").string();
  const auto file = [&](const std::string& lip) {
    std::ofstream(path) << "format: omnistereo-detections/1\nimages:\n  - file: a.png\n"
                           "    width: 10\n    height: 10\n    lips:\n      - "
                        << lip << "\n";
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{mirror: 1, edge: middle, points: [[1, 2]]}", "images[0].lips[0].edge"},
      {"{mirror: 1, edge: inner, circle: r_middle, points: [[1, 2]]}", "images[0].lips[0].circle"},
      {"{mirror: 1, edge: inner, path: via_mirror3, points: [[1, 2]]}", "images[0].lips[0].path"},
      {"{mirror: 1, edge: inner, path: via_mirror2, points: [[1, 2]]}", "images[0].lips[0].path"},
      {"{mirror: 3, edge: inner, points: [[1, 2]]}", "images[0].lips[0].mirror"},
  };
  for (const auto& [lip, key] : cases) {
    file(lip);
    try {
      ReadDetectionsFile(path);
      ADD_FAILURE() << "accepted " << lip;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path + ": " + key + ":"), std::string::npos)
          << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
  file("{mirror: 2, edge: outer, points: [[1, 2], [3, 4]]}");
  const Observations unlabelled = ReadDetectionsFile(path);
  ASSERT_EQ(unlabelled.images.at(0).lips.size(), 1u);
  const LipEdgeObservation& edge = unlabelled.images[0].lips[0];
  EXPECT_TRUE(edge.mirror == Mirror::kTwo && edge.edge == BandEdge::kOuter);
  EXPECT_FALSE(edge.path.has_value());
  EXPECT_FALSE(edge.circle.has_value());
  EXPECT_EQ(edge.points.size(), 2u);
  fs::remove(path);
}

}  // namespace
}  // namespace omni::io

namespace omni::io {
namespace {

// init --images 'render/*.jpg' --out work/session.yaml: photos given relative to the working
// folder are written as the session's folder reads them (relative to it where they lie under
// it, else absolute), so that detect finds them; the model beside the session stays relative.
TEST(SessionText, PathsGivenFromTheWorkingFolderAreWrittenAsTheSessionReadsThem) {
  const fs::path root = fs::temp_directory_path() / "omni_session_paths_test";
  fs::remove_all(root);
  fs::create_directories(root / "render");
  fs::create_directories(root / "work" / "photos");
  std::ofstream(root / "render" / "0001.jpg") << "x";
  std::ofstream(root / "work" / "photos" / "0002.jpg") << "x";
  const fs::path before = fs::current_path();
  fs::current_path(root);
  Session s;
  s.model_path = (root / "work" / "start_model.yaml").string();
  s.images = {"render/0001.jpg", "work/photos/0002.jpg"};
  TargetSpec board;
  board.type = TargetType::kChessboard;
  board.rows = 5;
  board.cols = 6;
  board.square_mm = 35;
  s.targets = {board};
  const std::string text = SessionText(s, "work");
  fs::current_path(before);
  EXPECT_NE(text.find("model: \"start_model.yaml\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"" + (root / "render" / "0001.jpg").string() + "\""), std::string::npos)
      << text;
  EXPECT_NE(text.find("\"photos/0002.jpg\""), std::string::npos) << text;
  io::WriteFileAtomically((root / "work" / "session.yaml").string(), text);
  const Session back = ReadSessionFile((root / "work" / "session.yaml").string());
  ASSERT_EQ(back.images.size(), 2u);
  for (const std::string& image : back.images) EXPECT_TRUE(fs::exists(image)) << image;
  fs::remove_all(root);
}

}  // namespace
}  // namespace omni::io
