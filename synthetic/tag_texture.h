// Printed tag-grid sheets as images: the textures POV-Ray maps onto a target's sheet rectangle.
//
// The image is the printed face seen from the printed side: column 0 at the sheet's x0, row 0 at
// its y0 (model/target.h: y runs down the face), covering SheetBounds(spec) exactly. Tag bits
// come from libapriltag's tag36h11 family (apriltag_to_image, the library's own tag image):
//   apriltag_grid:    libapriltag's tag as is: 1-bit black border of an 8-bit black square
//                     (tag_size), 6x6 data bits, white around;
//   kalibr_aprilgrid: kalibr_create_target_pdf's tag: the same 6x6 data bits inside a 2-bit black
//                     border (10 bits = tag_size, no white border of its own), and black squares
//                     of side spacing * tag_size at every crossing of the gaps, including the
//                     outer frame (the script draws one at each tag's four diagonal corners).
//                     Its tag36h11 codes are the pre-AprilTag-3 integers of the same patterns.
// Pixels are square and a whole number per tag bit, chosen so that every tag edge, gap and
// corner square lies on a pixel boundary: the map is exact, not rounded.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "model/target.h"

namespace omni::synthetic {

// Tag bits across tag_size: 8 (apriltag_grid) or 10 (kalibr_aprilgrid).
int TagBitsAcross(const TargetSpec& spec);

// Checks that a tag grid can be printed exactly: known family, ids inside it, spacing leaving at
// least one white bit between plain tags, gaps a whole number of texture pixels. False with a
// one-line reason otherwise.
bool CheckTagGrid(const TargetSpec& spec, std::string* error);

// The smallest whole number of pixels per tag bit (>= min_pixels_per_bit) that puts every gap on
// a pixel boundary; 0 if there is none up to 64.
int TexturePixelsPerBit(const TargetSpec& spec, int min_pixels_per_bit = 4);

struct TagTexture {
  cv::Mat image;              // CV_8UC1: 0 black, 255 white
  double mm_per_pixel = 0.0;  // square pixels
  int pixels_per_bit = 0;
};

// The sheet image of a tag grid (CheckTagGrid must hold).
TagTexture MakeTagTexture(const TargetSpec& spec, int min_pixels_per_bit = 4);

// The printed face of ANY target over SheetBounds(spec): tag grids as MakeTagTexture; a
// chessboard as one pixel per square (mm_per_pixel = square), its (cols + 1) x (rows + 1) squares
// in a one-square white margin, cell (i, j) (x from i * square, y from j * square, i, j >= -1)
// black where i + j is odd, as the renderer's POV-Ray checker paints it (pov_scene.cc). What
// `omnistereo target` prints.
TagTexture SheetTexture(const TargetSpec& spec);

// The texture's file name for target `index` of a scene ("target<index>_<type>.png").
std::string TextureFileName(int index, const TargetSpec& spec);

// Writes the texture PNG of every tag-grid target into `folder` (TextureFileName names). False
// with a reason if a file cannot be written.
bool WriteTagTextures(const std::vector<TargetSpec>& targets, const std::string& folder,
                      std::string* error);

}  // namespace omni::synthetic
