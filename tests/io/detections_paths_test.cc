// io/detections_file.h's paths: a detections file names its images and session relative to its
// own folder (WithPathsRelativeToFile), and its images are found from either folder (ImagePathsOf).
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "io/detections_file.h"
#include "tests/temp_dir.h"

namespace omni::io {
namespace {

namespace fs = std::filesystem;

TEST(DetectionsPaths, RelativeToTheFilesFolderWhereBelowIt) {
  const fs::path dir = fs::absolute(testing::UniqueTempDir("omni_detections_paths")) / "run";
  Observations d;
  d.session = (dir / "session.yaml").string();
  d.images.resize(3);
  d.images[0].file = (dir / "images" / "0001.png").string();
  d.images[1].file = "/elsewhere/0002.png";  // not below: as given
  d.images[2].file = (dir / "sub" / ".." / "0003.png").string();
  const Observations r = WithPathsRelativeToFile(d, (dir / "detections.yaml").string());
  EXPECT_EQ(r.session, "session.yaml");
  EXPECT_EQ(r.images[0].file, "images/0001.png");
  EXPECT_EQ(r.images[1].file, "/elsewhere/0002.png");
  EXPECT_EQ(r.images[2].file, "0003.png");
}

TEST(DetectionsPaths, ImagesFoundAsWrittenOrBesideTheFileElseTheSessions) {
  const fs::path dir = testing::UniqueTempDir("omni_detections_images");
  fs::create_directories(dir / "out" / "images");
  std::ofstream(dir / "out" / "images" / "0001.png") << "x";
  std::ofstream(dir / "0002.png") << "x";
  Observations d;
  d.images.resize(4);
  d.images[0].file = "images/0001.png";           // relative to the detections file's folder
  d.images[1].file = (dir / "0002.png").string();  // as written
  d.images[2].file = "missing.png";                // the session's of that index
  d.images[3].file = "missing_too.png";            // none: as written
  const std::string detections = (dir / "out" / "detections.yaml").string();
  const std::vector<std::string> paths =
      ImagePathsOf(d, detections, {"s0.png", "s1.png", "s2.png"});
  ASSERT_EQ(paths.size(), 4u);
  EXPECT_EQ(paths[0], (dir / "out" / "images/0001.png").string());
  EXPECT_EQ(paths[1], (dir / "0002.png").string());
  EXPECT_EQ(paths[2], "s2.png");
  EXPECT_EQ(paths[3], "missing_too.png");
}

}  // namespace
}  // namespace omni::io
