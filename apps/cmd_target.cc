// `omnistereo target --type chessboard|apriltag_grid|kalibr_aprilgrid --rows R --cols C
// --size MM [--spacing S --first_id N] --out file.pdf|.svg|.png [--paper A4 --dpi 300]`
//: a printable target at its exact physical size (print/target_sheet.h), its session
// entry printed on stdout and on the sheet.
#include <cstdio>
#include <string>

#include <gflags/gflags.h>

#include "apps/command.h"
#include "apps/common_flags.h"
#include "io/file_util.h"
#include "io/session_file.h"
#include "print/target_sheet.h"
#include "synthetic/tag_texture.h"

DEFINE_string(type, "", "target type: chessboard | apriltag_grid | kalibr_aprilgrid");
DEFINE_int32(rows, 0, "chessboard: inner corners down; tag grids: tags down");
DEFINE_int32(cols, 0, "chessboard: inner corners across; tag grids: tags across");
DEFINE_double(size, 0, "chessboard: square side (mm); tag grids: tag side, the black square (mm)");
DEFINE_double(spacing, 0.3, "tag grids: gap between tags / tag side");
DEFINE_int32(first_id, 0, "tag grids: id of the first tag (tag36h11)");
DEFINE_string(paper, "A4", "paper: A4, A3, A2, A1, A0, letter (portrait or landscape, whichever holds the target)");
DEFINE_double(dpi, 300, "PNG only: dots per inch");

namespace omni::apps {
namespace {

std::string Extension(const std::string& path) {
  const auto dot = path.rfind('.');
  return dot == std::string::npos ? "" : path.substr(dot);
}

// The flags as a target; throws InputError naming the flag.
TargetSpec TargetFromFlags() {
  TargetSpec t;
  if (!ParseTargetType(FLAGS_type, &t.type)) {
    throw io::InputError("--type: expected chessboard, apriltag_grid or kalibr_aprilgrid, got '" +
                         FLAGS_type + "'");
  }
  if (FLAGS_rows < 1 || FLAGS_cols < 1) {
    throw io::InputError("--rows, --cols: expected whole numbers >= 1 (chessboard: inner corners)");
  }
  if (!(FLAGS_size > 0)) throw io::InputError("--size: expected the square or tag side in mm, > 0");
  t.rows = FLAGS_rows;
  t.cols = FLAGS_cols;
  if (t.type == TargetType::kChessboard) {
    t.square_mm = FLAGS_size;
    if (t.rows < 2 || t.cols < 2) throw io::InputError("--rows, --cols: a chessboard needs >= 2 inner corners each way");
    return t;
  }
  t.tag_size_mm = FLAGS_size;
  t.spacing = FLAGS_spacing;
  t.first_id = FLAGS_first_id;
  std::string error;
  if (!synthetic::CheckTagGrid(t, &error)) throw io::InputError("target: " + error);
  return t;
}

}  // namespace

int RunTarget() {
  if (FLAGS_out.empty()) throw io::InputError("--out: expected a .pdf, .svg or .png path");
  const std::string ext = Extension(FLAGS_out);
  if (ext != ".pdf" && ext != ".svg" && ext != ".png") {
    throw io::InputError("--out: expected a path ending in .pdf, .svg or .png, got '" + FLAGS_out + "'");
  }
  if (ext == ".png" && !(FLAGS_dpi >= 50 && FLAGS_dpi <= 2400)) {
    throw io::InputError("--dpi: expected 50..2400");
  }
  print::Paper paper;
  if (!print::PaperByName(FLAGS_paper, &paper)) {
    throw io::InputError("--paper: expected one of " + print::PaperNames() + ", got '" + FLAGS_paper + "'");
  }
  const TargetSpec target = TargetFromFlags();
  const print::TargetPage page = print::LayoutTargetPage(target, paper);
  const std::string bytes = ext == ".pdf"   ? print::PdfBytes(page)
                            : ext == ".svg" ? print::SvgText(page)
                                            : print::PngBytes(page, FLAGS_dpi);
  io::WriteFileAtomically(FLAGS_out, bytes);
  std::printf("%s: %s on %s %s (%.1f x %.1f mm), pattern %.1f x %.1f mm%s\n", FLAGS_out.c_str(),
              page.text[0].substr(page.text[0].find(':') + 2).c_str(), paper.name.c_str(),
              page.width_mm > page.height_mm ? "landscape" : "portrait", page.width_mm,
              page.height_mm, page.pattern.width, page.pattern.height,
              ext == ".png" ? (", " + std::to_string(static_cast<int>(FLAGS_dpi)) + " dpi").c_str() : "");
  std::printf("session entry (under targets:):\n  - %s\n", io::TargetEntryText(target).c_str());
  std::printf("print at 100%% and check the 100 mm bar with a ruler before measuring anything\n");
  return 0;
}

}  // namespace omni::apps
