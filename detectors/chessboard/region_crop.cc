#include "detectors/chessboard/region_crop.h"

namespace omni::detectors {

cv::Mat RegionCrop(const RingView& view, const cv::Rect& full) {
  const cv::Rect inside = full & cv::Rect(0, 0, view.width, view.height);
  const cv::Mat valid = view.map_x(inside) >= 0;
  int histogram[256] = {0}, total = 0;
  for (int y = 0; y < inside.height; ++y) {
    const uchar* g = view.image.ptr<uchar>(inside.y + y) + inside.x;
    const uchar* ok = valid.ptr<uchar>(y);
    for (int x = 0; x < inside.width; ++x) {
      if (!ok[x]) continue;
      ++histogram[g[x]];
      ++total;
    }
  }
  int white = 255;
  for (int level = 0, below = 0; level < 256; ++level) {
    below += histogram[level];
    if (total > 0 && below >= 0.9 * total) {
      white = level;
      break;
    }
  }
  cv::Mat crop(full.size(), CV_8U, cv::Scalar(white));
  const cv::Rect dst(inside.tl() - full.tl(), inside.size());
  view.image(inside).copyTo(crop(dst));
  crop(dst).setTo(white, ~valid);
  return crop;
}

}  // namespace omni::detectors
