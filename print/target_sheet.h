// Printable calibration targets: a target drawn at its exact physical size on a
// sheet of paper, as PDF (cairo), SVG (text) or PNG (cairo, at a stated dpi), from the same
// texture the renderer maps onto its targets (synthetic/tag_texture.h SheetTexture), so that
// what is printed is what the detectors are tested on.
//
// The page: the target's pattern (its black cells) centred in the printable area (the page's
// white margins are its quiet zone), portrait unless only landscape holds it; below it, in the bottom margin, the
// target in words, its session entry (io/session_file.h TargetEntryText) and a 100 mm
// scale bar with 10 mm ticks to check the printer's scale. Every length is in mm from the page's
// top-left corner.
#pragma once

#include <string>
#include <vector>

#include "model/target.h"

namespace omni::print {

struct Paper {
  std::string name;
  double width_mm = 0, height_mm = 0;  // portrait
};
// A4, A3, A2, A1, A0, letter; false if unknown.
bool PaperByName(const std::string& name, Paper* paper);
std::string PaperNames();  // "A4, A3, A2, A1, A0, letter"

struct RectMm {
  double x = 0, y = 0, width = 0, height = 0;
};

struct TargetPage {
  double width_mm = 0, height_mm = 0;  // the page as placed (landscape swaps them)
  RectMm sheet;                         // the target's sheet (SheetBounds) on the page: may
                                        // reach into the margins, which are white anyway
  RectMm pattern;                       // the extent of its black cells
  std::vector<RectMm> black;            // the target's black cells, merged into rectangles
  std::vector<RectMm> scale_bar;        // the 100 mm bar and its ticks (black)
  double text_x_mm = 0, text_y_mm = 0, text_size_mm = 3;  // first text line's baseline
  std::vector<std::string> text;
};

// The page of `target` on `paper`. Throws omni::InputError naming the target's size and the
// paper's printable area when it does not fit (margins kMarginMm, kFooterMm).
inline constexpr double kMarginMm = 10, kFooterMm = 22;
TargetPage LayoutTargetPage(const TargetSpec& target, const Paper& paper);

// The page as a file: PDF (vector, via cairo), SVG (vector, mm units), PNG (at `dpi`, with its
// pHYs chunk saying so). Returns the file's bytes.
std::string PdfBytes(const TargetPage& page);
std::string SvgText(const TargetPage& page);
std::string PngBytes(const TargetPage& page, double dpi);

}  // namespace omni::print
