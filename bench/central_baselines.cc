// Central baselines on real photos: the figures of the usual central models on the SAME corners
// our non-central model will see, trained on some photos and scored on held-out ones with only the
// board poses re-estimated (model fixed), as BabelCalib and mrcal report them.
//   bench_central_baselines --photos DIR --rows 6 --cols 8 --square_mm 42
//   bench_central_baselines --corners FILE [--photos DIR] ...
// Corners: OpenCV's chessboard detector on each whole photo (--detector sb: findChessboardCornersSB,
// classic: findChessboardCorners + cornerSubPix); photos where it fails are named and left out. Or
// a corners file (our own detector's, or one written by --write_corners):
//   image_size W H
//   photo NAME
//   ID U V          one line per corner; ID = row * cols + col of the inner-corner grid
// ('#' starts a comment). Board point of ID: (col, row, 0) * square, in metres.
// Split: --holdout NAMES_OR_1_BASED_INDICES (comma-separated), default every third photo (3, 6,
// 9, ...); --folds K adds K-fold cross-validation (fold f holds out photos i with i % K == f).
// Indices count every photo of the folder or file, with or without a board found.
// Models (bench/central_models.h): the unified model by cv::omnidir::calibrate (skew fixed by
// default, --omnidir_flags), which drops photos whose initialisation fails (named here), and an
// OCamCalib-style polynomial (centre, affine c d e, a0 a2 a3 a4) from Scaramuzza's linear estimate
// refined by Ceres. Figures: 2D RMS per corner, sqrt(mean |projected - measured|^2), px, per photo
// and over all, training (with the fit's own poses) and held-out (poses fitted, model fixed).
// Photos dropped by omnidir are also scored pose-only and reported apart.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gflags/gflags.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/central_models.h"

DEFINE_string(photos, "", "folder of photos (.pgm .png .jpg .jpeg .bmp .tif .tiff), read in name order");
DEFINE_string(corners, "", "corners file instead of detecting (format in the file header)");
DEFINE_string(write_corners, "", "write the detected corners to this file (same format)");
DEFINE_int32(rows, 6, "inner-corner rows of the chessboard");
DEFINE_int32(cols, 8, "inner-corner columns of the chessboard");
DEFINE_double(square_mm, 42, "chessboard square side, mm");
DEFINE_string(detector, "sb", "sb (findChessboardCornersSB) or classic (findChessboardCorners + cornerSubPix)");
DEFINE_string(holdout, "", "held-out photos: comma-separated names or 1-based indices (default: every third)");
DEFINE_int32(folds, 0, "also run K-fold cross-validation with this K (0: none)");
DEFINE_int32(omnidir_flags, cv::omnidir::CALIB_FIX_SKEW, "cv::omnidir::calibrate flags (2: fix skew)");
DEFINE_bool(per_photo, true, "print every photo's RMS");

namespace {

using omni::central::BoardView;
using omni::central::FitResult;
using omni::central::ModelKind;
using omni::central::Pose;

[[noreturn]] void Fail(const std::string& message) {
  std::fprintf(stderr, "bench_central_baselines: %s\n", message.c_str());
  std::exit(1);
}

struct Photo {
  std::string name;
  std::vector<int> ids;
  std::vector<Eigen::Vector2d> pixels;
};

struct Corners {
  int width = 0, height = 0;
  std::vector<Photo> photos;   // every photo, found or not
};

Eigen::Vector3d BoardPoint(int id) {
  const double square = FLAGS_square_mm / 1000.0;
  return Eigen::Vector3d((id % FLAGS_cols) * square, (id / FLAGS_cols) * square, 0.0);
}

std::vector<std::string> ListPhotos(const std::string& folder) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(folder)) Fail("--photos " + folder + ": not a folder");
  static const std::set<std::string> kExtensions = {".pgm", ".png", ".jpg", ".jpeg", ".bmp",
                                                    ".tif", ".tiff"};
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (entry.is_regular_file() && kExtensions.count(ext)) names.push_back(entry.path().filename());
  }
  std::sort(names.begin(), names.end());
  if (names.empty()) Fail("--photos " + folder + ": no photo (.pgm .png .jpg .bmp .tif) in it");
  return names;
}

Corners DetectCorners(const std::string& folder) {
  Corners corners;
  const cv::Size pattern(FLAGS_cols, FLAGS_rows);
  for (const std::string& name : ListPhotos(folder)) {
    const std::string path = (std::filesystem::path(folder) / name).string();
    const cv::Mat gray = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (gray.empty()) Fail(path + ": cannot be read as an image");
    if (corners.width == 0) {
      corners.width = gray.cols;
      corners.height = gray.rows;
    } else if (gray.cols != corners.width || gray.rows != corners.height) {
      Fail(path + ": " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
           ", expected the first photo's " + std::to_string(corners.width) + "x" +
           std::to_string(corners.height));
    }
    std::vector<cv::Point2f> found;
    bool ok = false;
    if (FLAGS_detector == "sb") {
      ok = cv::findChessboardCornersSB(gray, pattern, found,
                                       cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
    } else {
      ok = cv::findChessboardCorners(gray, pattern, found,
                                     cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      if (ok)
        cv::cornerSubPix(gray, found, cv::Size(5, 5), cv::Size(-1, -1),
                         cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
    }
    Photo photo;
    photo.name = name;
    if (ok) {
      for (size_t i = 0; i < found.size(); ++i) {
        photo.ids.push_back(static_cast<int>(i));
        photo.pixels.emplace_back(found[i].x, found[i].y);
      }
    }
    corners.photos.push_back(photo);
  }
  return corners;
}

Corners ReadCorners(const std::string& path) {
  std::ifstream in(path);
  if (!in) Fail(path + ": cannot be opened");
  Corners corners;
  std::string line;
  int line_number = 0;
  const int board_corners = FLAGS_rows * FLAGS_cols;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string key;
    if (!(fields >> key)) continue;
    const std::string where = path + ":" + std::to_string(line_number) + ": ";
    if (key == "image_size") {
      if (!(fields >> corners.width >> corners.height) || corners.width <= 0 || corners.height <= 0)
        Fail(where + "expected 'image_size W H' with positive integers");
    } else if (key == "photo") {
      Photo photo;
      if (!(fields >> photo.name)) Fail(where + "expected 'photo NAME'");
      corners.photos.push_back(photo);
    } else {
      if (corners.photos.empty()) Fail(where + "a corner line before any 'photo NAME' line");
      std::istringstream corner(line);
      int id;
      double u, v;
      if (!(corner >> id >> u >> v) || id < 0 || id >= board_corners)
        Fail(where + "expected 'ID U V' with 0 <= ID < rows * cols = " +
             std::to_string(board_corners));
      corners.photos.back().ids.push_back(id);
      corners.photos.back().pixels.emplace_back(u, v);
    }
  }
  if (corners.width == 0) Fail(path + ": no 'image_size W H' line");
  if (corners.photos.empty()) Fail(path + ": no 'photo NAME' line");
  return corners;
}

void WriteCorners(const Corners& corners, const std::string& path) {
  std::ofstream out(path);
  if (!out) Fail(path + ": cannot be written");
  out << "# corners of a " << FLAGS_rows << " x " << FLAGS_cols << " inner-corner chessboard, "
      << FLAGS_square_mm << " mm squares; ID = row * cols + col\n";
  out << "image_size " << corners.width << " " << corners.height << "\n";
  char buffer[96];
  for (const Photo& photo : corners.photos) {
    out << "photo " << photo.name << "\n";
    for (size_t i = 0; i < photo.ids.size(); ++i) {
      std::snprintf(buffer, sizeof(buffer), "%d %.6f %.6f\n", photo.ids[i], photo.pixels[i].x(),
                    photo.pixels[i].y());
      out << buffer;
    }
  }
}

BoardView ToView(const Photo& photo) {
  BoardView view;
  view.name = photo.name;
  for (size_t i = 0; i < photo.ids.size(); ++i) {
    view.points_in_board.push_back(BoardPoint(photo.ids[i]));
    view.pixels.push_back(photo.pixels[i]);
  }
  return view;
}

struct Score {
  std::vector<double> errors;  // pooled per-corner 2D errors
  int photos = 0, failed = 0, invalid = 0;
  void Add(const std::vector<double>& e, int misses) {
    errors.insert(errors.end(), e.begin(), e.end());
    invalid += misses;
    ++photos;
  }
};

std::string Figure(const Score& score) {
  char buffer[160];
  std::snprintf(buffer, sizeof(buffer), "%.3f px (%d photos, %zu corners%s)",
                omni::central::Rms(score.errors), score.photos, score.errors.size(),
                score.failed || score.invalid
                    ? (", " + std::to_string(score.failed) + " pose fits failed, " +
                       std::to_string(score.invalid) + " corners unprojectable").c_str()
                    : "");
  return buffer;
}

struct ModelScores {
  Score train, held_out, dropped;
  bool ok = false;
};

ModelScores RunModel(ModelKind kind, const std::vector<BoardView>& train,
                     const std::vector<BoardView>& held_out, int width, int height) {
  ModelScores scores;
  std::printf("  %s\n", omni::central::ModelName(kind));
  const FitResult fit =
      kind == ModelKind::kUnified
          ? omni::central::FitUnifiedOmnidir(train, width, height, FLAGS_omnidir_flags)
          : omni::central::FitPolynomial(train, width, height);
  if (!fit.ok) {
    std::printf("    fit FAILED: %s\n", fit.message.c_str());
    return scores;
  }
  scores.ok = true;
  const std::vector<std::string> names = omni::central::ParamNames(kind);
  std::printf("    params:");
  for (size_t i = 0; i < names.size(); ++i) std::printf(" %s=%.6g", names[i].c_str(), fit.params[i]);
  std::printf("\n    used %zu of %zu training photos", fit.used.size(), train.size());
  std::vector<bool> used(train.size(), false);
  for (int v : fit.used) used[v] = true;
  std::string dropped;
  for (size_t v = 0; v < train.size(); ++v)
    if (!used[v]) dropped += " " + train[v].name;
  std::printf("%s%s\n", dropped.empty() ? "" : "; dropped:", dropped.c_str());
  if (kind == ModelKind::kUnified)
    std::printf("    cv::omnidir::calibrate's own returned RMS: %.4f\n", fit.tool_rms);
  auto report = [&](const char* role, const BoardView& view, const std::optional<Pose>& pose,
                    Score* score) {
    if (!pose) {
      ++score->failed;
      std::printf("    %-24s %-9s pose fit FAILED\n", view.name.c_str(), role);
      return;
    }
    int misses = 0;
    const std::vector<double> e = omni::central::CornerErrors(kind, fit.params, *pose, view, &misses);
    score->Add(e, misses);
    if (FLAGS_per_photo)
      std::printf("    %-24s %-9s %3zu corners  rms %.3f px  max %.3f px%s\n", view.name.c_str(),
                  role, e.size(), omni::central::Rms(e),
                  e.empty() ? 0.0 : *std::max_element(e.begin(), e.end()),
                  misses ? (" (" + std::to_string(misses) + " unprojectable)").c_str() : "");
  };
  for (size_t k = 0; k < fit.used.size(); ++k)
    report("train", train[fit.used[k]], fit.poses[k], &scores.train);
  for (size_t v = 0; v < train.size(); ++v)
    if (!used[v])
      report("dropped", train[v], omni::central::FitPose(kind, fit.params, train[v]),
             &scores.dropped);
  for (const BoardView& view : held_out)
    report("held-out", view, omni::central::FitPose(kind, fit.params, view), &scores.held_out);
  std::printf("    training RMS %s\n", Figure(scores.train).c_str());
  std::printf("    held-out RMS %s\n", Figure(scores.held_out).c_str());
  if (scores.dropped.photos || scores.dropped.failed)
    std::printf("    dropped photos, pose-only RMS %s\n", Figure(scores.dropped).c_str());
  return scores;
}

// Indices are 1-based positions in the photo list (folder or corners file), photos without a
// board included, so that a split holds out the same photos whichever detector found corners.
std::vector<bool> ParseHoldout(const std::string& spec, const std::vector<BoardView>& views,
                               const std::vector<int>& photo_index) {
  std::vector<bool> held(views.size(), false);
  if (spec.empty()) {
    for (size_t i = 0; i < views.size(); ++i) held[i] = photo_index[i] % 3 == 2;
    return held;
  }
  std::stringstream items(spec);
  std::string item;
  while (std::getline(items, item, ',')) {
    if (item.empty()) continue;
    bool matched = false;
    for (size_t i = 0; i < views.size(); ++i) {
      if (views[i].name == item || std::to_string(photo_index[i] + 1) == item) {
        held[i] = true;
        matched = true;
      }
    }
    if (!matched)
      Fail("--holdout: '" + item + "' is neither the name nor the 1-based index of a photo with a board");
  }
  return held;
}

void RunSplit(const std::string& title, const std::vector<BoardView>& views,
              const std::vector<bool>& held, int width, int height,
              std::map<ModelKind, std::vector<ModelScores>>* all) {
  std::vector<BoardView> train, held_out;
  std::string held_names;
  for (size_t i = 0; i < views.size(); ++i) {
    (held[i] ? held_out : train).push_back(views[i]);
    if (held[i]) held_names += " " + views[i].name;
  }
  std::printf("\n== %s: %zu training, %zu held-out:%s\n", title.c_str(), train.size(),
              held_out.size(), held_names.c_str());
  if (train.size() < 3) {
    std::printf("  fewer than 3 training photos: skipped\n");
    return;
  }
  for (ModelKind kind : {ModelKind::kUnified, ModelKind::kPolynomial})
    (*all)[kind].push_back(RunModel(kind, train, held_out, width, height));
}

}  // namespace

int main(int argc, char** argv) {
  gflags::SetUsageMessage(
      "central baselines (cv::omnidir unified, OCamCalib-style polynomial) on real photos:\n"
      "  bench_central_baselines --photos DIR [--rows 6 --cols 8 --square_mm 42]\n"
      "  bench_central_baselines --corners FILE [--rows R --cols C --square_mm S]\n"
      "Trains on ~2/3 of the photos, scores the rest with only the board poses re-estimated;\n"
      "figures are 2D RMS per corner in px (bench/central_baselines.cc header).");
  gflags::ParseCommandLineFlags(&argc, &argv, true);
  if (argc > 1) Fail(std::string("unexpected argument '") + argv[1] + "' (see --help)");
  if (FLAGS_photos.empty() && FLAGS_corners.empty()) Fail("give --photos DIR or --corners FILE (see --help)");
  if (FLAGS_rows < 2 || FLAGS_cols < 2) Fail("--rows and --cols must be at least 2");
  if (!(FLAGS_square_mm > 0)) Fail("--square_mm must be positive");
  if (FLAGS_detector != "sb" && FLAGS_detector != "classic")
    Fail("--detector must be sb or classic, not '" + FLAGS_detector + "'");
  if (FLAGS_folds < 0 || FLAGS_folds == 1) Fail("--folds must be 0 (none) or at least 2");

  const Corners corners =
      FLAGS_corners.empty() ? DetectCorners(FLAGS_photos) : ReadCorners(FLAGS_corners);
  if (!FLAGS_write_corners.empty()) WriteCorners(corners, FLAGS_write_corners);

  std::printf("board %d x %d inner corners, %.3g mm squares; image %d x %d; corners from %s\n",
              FLAGS_rows, FLAGS_cols, FLAGS_square_mm, corners.width, corners.height,
              FLAGS_corners.empty() ? ("OpenCV's " + FLAGS_detector + " detector on " + FLAGS_photos).c_str()
                                    : FLAGS_corners.c_str());
  std::vector<BoardView> views;
  std::vector<int> photo_index;  // of each view in corners.photos
  std::string missing;
  size_t total_corners = 0;
  for (const Photo& photo : corners.photos) {
    if (photo.ids.size() < 6) {
      missing += " " + photo.name;
      continue;
    }
    views.push_back(ToView(photo));
    photo_index.push_back(static_cast<int>(&photo - corners.photos.data()));
    total_corners += photo.ids.size();
  }
  std::printf("photos: %zu; with a board: %zu (%zu corners)%s%s\n", corners.photos.size(),
              views.size(), total_corners, missing.empty() ? "" : "; no board found in:",
              missing.c_str());
  if (views.size() < 4) Fail("fewer than 4 photos with a board: nothing to train and hold out");

  std::map<ModelKind, std::vector<ModelScores>> split_scores, fold_scores;
  RunSplit("split", views, ParseHoldout(FLAGS_holdout, views, photo_index), corners.width, corners.height,
           &split_scores);
  for (int f = 0; f < FLAGS_folds; ++f) {
    std::vector<bool> held(views.size());
    for (size_t i = 0; i < views.size(); ++i) held[i] = photo_index[i] % FLAGS_folds == f;
    RunSplit("fold " + std::to_string(f + 1) + " of " + std::to_string(FLAGS_folds), views, held,
             corners.width, corners.height, &fold_scores);
  }

  std::printf("\n== summary (2D RMS per corner, px)\n");
  for (ModelKind kind : {ModelKind::kUnified, ModelKind::kPolynomial}) {
    std::printf("%s\n", omni::central::ModelName(kind));
    for (const ModelScores& s : split_scores[kind]) {
      if (!s.ok) continue;
      std::printf("  split      training %s\n             held-out %s\n",
                  Figure(s.train).c_str(), Figure(s.held_out).c_str());
    }
    if (FLAGS_folds > 0) {
      Score train, held_out;
      for (const ModelScores& s : fold_scores[kind]) {
        if (!s.ok) continue;
        train.errors.insert(train.errors.end(), s.train.errors.begin(), s.train.errors.end());
        train.photos += s.train.photos;
        held_out.errors.insert(held_out.errors.end(), s.held_out.errors.begin(),
                               s.held_out.errors.end());
        held_out.photos += s.held_out.photos;
        held_out.failed += s.held_out.failed;
        held_out.invalid += s.held_out.invalid;
      }
      std::printf("  %d folds    training %s (pooled over folds)\n             held-out %s "
                  "(each photo held out once)\n",
                  FLAGS_folds, Figure(train).c_str(), Figure(held_out).c_str());
    }
  }
  return 0;
}
