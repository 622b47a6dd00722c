#include "model/truth.h"

#include <algorithm>

namespace omni {

TrueCornerMatch NearestTrueCorner(const std::vector<TruthCorner>& corners,
                                  const std::optional<Eigen::Vector2d> (&pixel)[2], double max_px,
                                  const std::function<bool(const TruthCorner&)>& admit) {
  TrueCornerMatch best;
  for (const TruthCorner& c : corners) {
    if (admit && !admit(c)) continue;
    double d = 0;
    bool seen = true;
    for (int m = 0; m < 2 && seen; ++m) {
      if (!pixel[m]) continue;
      seen = c.pixel[m].has_value();
      if (seen) d = std::max(d, (*c.pixel[m] - *pixel[m]).norm());
    }
    if (seen && d < max_px && d < best.distance_px) best = {&c, d};
  }
  return best;
}

TrueCornerMatch NearestTrueCorner(const std::vector<TruthCorner>& corners, Mirror mirror,
                                  const Eigen::Vector2d& pixel, double max_px,
                                  const std::function<bool(const TruthCorner&)>& admit) {
  std::optional<Eigen::Vector2d> pixels[2];
  pixels[MirrorIndex(mirror) - 1] = pixel;
  return NearestTrueCorner(corners, pixels, max_px, admit);
}

}  // namespace omni
