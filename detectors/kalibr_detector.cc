#include "detectors/kalibr_detector.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <unordered_map>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace omni::detectors {
namespace {

// A Kalibr tag is 10 bits across: 2 black border bits each side around tag36h11's 6 x 6 data
// bits; libapriltag's bit_x/bit_y count from its own 1-bit border, hence the +1.
constexpr int kBits = 10;
constexpr int kBorderShift = 1;

// tag36h11's codes (index by exact code) and bit positions, read once.
struct Family {
  std::vector<uint32_t> bit_x, bit_y;
  uint32_t nbits = 0;
  std::unordered_map<uint64_t, int> id_of_code;
};

const Family& Tag36h11() {
  static const Family family = [] {
    Family f;
    std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> lib(tag36h11_create(),
                                                                        tag36h11_destroy);
    f.nbits = lib->nbits;
    f.bit_x.assign(lib->bit_x, lib->bit_x + lib->nbits);
    f.bit_y.assign(lib->bit_y, lib->bit_y + lib->nbits);
    for (uint32_t i = 0; i < lib->ncodes; ++i) f.id_of_code[lib->codes[i]] = static_cast<int>(i);
    return f;
  }();
  return family;
}

double Bilinear(const cv::Mat& grey, double u, double v) {
  if (!(u >= 0 && v >= 0 && u < grey.cols - 1 && v < grey.rows - 1)) return -1;
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const double a = u - x, b = v - y;
  const uchar* r0 = grey.ptr<uchar>(y);
  const uchar* r1 = grey.ptr<uchar>(y + 1);
  return (1 - b) * ((1 - a) * r0[x] + a * r0[x + 1]) + b * ((1 - a) * r1[x] + a * r1[x + 1]);
}

// Mean grey of the middle of one bit cell (cx, cy in bits from the tag's top-left outer corner,
// may be outside the tag), through the homography tag bits -> view pixels. -1 outside the view.
double CellValue(const cv::Mat& grey, const cv::Matx33d& H, double cx, double cy) {
  double sum = 0;
  for (double a : {-0.2, 0.0, 0.2}) {
    for (double b : {-0.2, 0.0, 0.2}) {
      const cv::Vec3d p = H * cv::Vec3d(cx + 0.5 + a, cy + 0.5 + b, 1.0);
      const double value = Bilinear(grey, p[0] / p[2], p[1] / p[2]);
      if (value < 0) return -1;
      sum += value;
    }
  }
  return sum / 9;
}

// Reads the tag whose outer corners in the view are quad[(r + j) % 4], j = top-left, top-right,
// bottom-right, bottom-left as printed. Returns the tag id or -1.
int DecodeRotation(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad, int r,
                   const KalibrDetectorOptions& options, cv::Matx33d* H_out) {
  const cv::Point2f tag[4] = {{0, 0}, {kBits, 0}, {kBits, kBits}, {0, kBits}};
  cv::Point2f image[4];
  for (int j = 0; j < 4; ++j) image[j] = quad[(r + j) % 4];
  const cv::Matx33d H(cv::getPerspectiveTransform(tag, image));
  // Black: the 2-bit border. White: the middle of the gap (3 bits wide) along each side, clear
  // of the corner squares.
  double black = 0, black_max = 0, white = 0;
  int n_black = 0, n_white = 0;
  for (int y = 0; y < kBits; ++y) {
    for (int x = 0; x < kBits; ++x) {
      if (x >= 2 && x < kBits - 2 && y >= 2 && y < kBits - 2) continue;
      const double v = CellValue(grey, H, x, y);
      if (v < 0) return -1;
      black += v;
      black_max = std::max(black_max, v);
      ++n_black;
    }
  }
  for (int i = 1; i < kBits - 1; ++i) {
    for (const auto& [cx, cy] : {std::pair<double, double>{i, -1.5}, {i, kBits + 0.5},
                                 {-1.5, i}, {kBits + 0.5, i}}) {
      const double v = CellValue(grey, H, cx, cy);
      if (v < 0) continue;
      white += v;
      ++n_white;
    }
  }
  if (n_white < kBits) return -1;
  black /= n_black;
  white /= n_white;
  const double contrast = white - black;
  if (contrast < options.min_contrast) return -1;
  const double threshold = 0.5 * (black + white);
  if (black_max > threshold) return -1;
  const Family& family = Tag36h11();
  uint64_t code = 0;
  for (uint32_t i = 0; i < family.nbits; ++i) {
    const double v = CellValue(grey, H, family.bit_x[i] + kBorderShift, family.bit_y[i] + kBorderShift);
    if (v < 0 || std::abs(v - threshold) < options.min_bit_margin * contrast) return -1;
    code = (code << 1) | (v > threshold ? 1u : 0u);
  }
  const auto it = family.id_of_code.find(code);
  if (it == family.id_of_code.end()) return -1;
  *H_out = H;
  return it->second;
}

// Reads a quad (view pixels, TL, TR, BR, BL as printed up to a rotation) in all four rotations:
// the tag id and its homography tag bits -> view pixels, or -1 if no rotation or more than one
// reads (two readings of one quad: neither is trusted).
int DecodeQuad(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
               const KalibrDetectorOptions& options, cv::Matx33d* H) {
  int id = -1;
  for (int r = 0; r < 4; ++r) {
    cv::Matx33d H_r;
    const int id_r = DecodeRotation(grey, quad, r, options, &H_r);
    if (id_r < 0) continue;
    if (id >= 0) return -1;
    id = id_r;
    *H = H_r;
  }
  return id;
}

// True if the quad's 6 x 6 data cells are all within min_contrast grey levels of each other:
// a solid square (Kalibr's corner squares) or an empty frame, not a tag, however its corners are
// placed (tag36h11 codes have 10 to 25 of their 36 bits light). -1 cells (outside the view) count as
// not uniform.
bool DataAreaIsUniform(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                       int min_contrast) {
  const cv::Point2f tag[4] = {{0, 0}, {kBits, 0}, {kBits, kBits}, {0, kBits}};
  const cv::Matx33d H(cv::getPerspectiveTransform(tag, quad.data()));
  double lo = 1e9, hi = -1e9;
  for (int y = 2; y < kBits - 2; ++y) {
    for (int x = 2; x < kBits - 2; ++x) {
      const double v = CellValue(grey, H, x, y);
      if (v < 0) return false;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return hi - lo < min_contrast;
}

// True if `p` lies inside one of `tags` (their corners in the view).
bool InsideAnyTag(const std::vector<KalibrViewTag>& tags, const cv::Point2f& p) {
  for (const KalibrViewTag& t : tags) {
    std::vector<cv::Point2f> polygon;
    for (const Eigen::Vector2d& c : t.corners) {
      polygon.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
    }
    if (cv::pointPolygonTest(polygon, p, false) > 0) return true;
  }
  return false;
}

// The quad's corners refined as X-junctions (RefineSaddleCorner) with the window the decoded
// tags' corners get (0.15 side: the 2-bit border around the corner), each allowed to move up to
// 0.2 side (well short of the corner square's far corners, 0.42 side away). False if any fails
// or is not a Kalibr X-junction (IsKalibrXJunction: dark tag and corner square, light gaps) as
// every tag corner is; quads of other things (plain tags' L-corners, blobs) stop here, unread.
bool RefineQuadCorners(const cv::Mat& grey, const std::array<cv::Point2f, 4>& quad,
                       int min_contrast, std::array<cv::Point2f, 4>* refined) {
  double side = 0;
  for (int k = 0; k < 4; ++k) side += 0.25 * cv::norm(quad[k] - quad[(k + 1) % 4]);
  const int half = static_cast<int>(std::lround(0.15 * side));
  for (int k = 0; k < 4; ++k) {
    Eigen::Vector2d corner;
    if (!RefineSaddleCorner(grey, Eigen::Vector2d(quad[k].x, quad[k].y), half, 0.2 * side,
                            &corner)) {
      return false;
    }
    (*refined)[k] = cv::Point2f(static_cast<float>(corner.x()), static_cast<float>(corner.y()));
  }
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d at((*refined)[k].x, (*refined)[k].y);
    const cv::Point2f next = (*refined)[(k + 1) % 4], previous = (*refined)[(k + 3) % 4];
    const Eigen::Vector2d to_next = (Eigen::Vector2d(next.x, next.y) - at).normalized();
    const Eigen::Vector2d to_previous = (Eigen::Vector2d(previous.x, previous.y) - at).normalized();
    if (!IsKalibrXJunction(grey, at, to_next, to_previous, std::max(1.5, 0.12 * side),
                           min_contrast)) {
      return false;
    }
  }
  return true;
}

// The intersection of two lines given as (vx, vy, x0, y0) from cv::fitLine.
bool Intersect(const cv::Vec4f& a, const cv::Vec4f& b, cv::Point2f* p) {
  const double det = a[0] * b[1] - a[1] * b[0];
  if (std::abs(det) < 1e-6) return false;
  const double t = ((b[2] - a[2]) * b[1] - (b[3] - a[3]) * b[0]) / det;
  *p = cv::Point2f(static_cast<float>(a[2] + t * a[0]), static_cast<float>(a[3] + t * a[1]));
  return true;
}

// The four corners of a quadrilateral contour: lines fitted to the middle of each side of its
// polygon approximation, intersected. Ordered with positive shoelace area in image coordinates
// (clockwise on screen, as the printed tag's TL, TR, BR, BL).
bool FitQuad(const std::vector<cv::Point>& contour, double min_side,
             std::array<cv::Point2f, 4>* quad) {
  const double perimeter = cv::arcLength(contour, true);
  if (perimeter < 4 * min_side) return false;
  std::vector<cv::Point> poly;
  cv::approxPolyDP(contour, poly, 0.06 * perimeter, true);
  if (poly.size() != 4 || !cv::isContourConvex(poly)) return false;
  // Index of each polygon vertex on the contour.
  std::array<int, 4> at{};
  for (int j = 0; j < 4; ++j) {
    at[j] = static_cast<int>(std::find(contour.begin(), contour.end(), poly[j]) - contour.begin());
  }
  const int n = static_cast<int>(contour.size());
  std::array<cv::Vec4f, 4> lines;
  for (int j = 0; j < 4; ++j) {
    const int a = at[j], b = at[(j + 1) % 4];
    const int len = ((b - a) % n + n) % n;
    if (len < 4) return false;
    std::vector<cv::Point2f> side;
    for (int i = len / 5; i <= len - len / 5; ++i) side.emplace_back(contour[(a + i) % n]);
    cv::fitLine(side, lines[j], cv::DIST_L2, 0, 0.01, 0.01);
  }
  for (int j = 0; j < 4; ++j) {
    if (!Intersect(lines[(j + 3) % 4], lines[j], &(*quad)[j])) return false;
  }
  double area = 0;
  for (int j = 0; j < 4; ++j) {
    const cv::Point2f& p = (*quad)[j];
    const cv::Point2f& q = (*quad)[(j + 1) % 4];
    area += p.x * q.y - q.x * p.y;
  }
  if (area < 0) std::reverse(quad->begin(), quad->end());
  return true;
}

}  // namespace

void DropTagsInconsistentWithNeighbours(const TargetSpec& target, double max_neighbour_error,
                                        std::vector<KalibrViewTag>* tags) {
  if (tags->size() < 2) return;
  std::vector<cv::Point2f> plane, view;
  for (const KalibrViewTag& t : *tags) {
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d p = CornerInTarget(target, 4 * t.tag_id + k);
      plane.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
      view.emplace_back(static_cast<float>(t.corners[k].x()), static_cast<float>(t.corners[k].y()));
    }
  }
  double side = 0;
  for (const KalibrViewTag& t : *tags) side += (t.corners[1] - t.corners[0]).norm() / tags->size();
  const double tolerance = max_neighbour_error * side;
  const cv::Mat H = cv::findHomography(plane, view, cv::RANSAC, tolerance);
  if (H.empty()) {
    tags->clear();
    return;
  }
  std::vector<cv::Point2f> predicted;
  cv::perspectiveTransform(plane, predicted, H);
  std::vector<KalibrViewTag> kept;
  for (std::size_t i = 0; i < tags->size(); ++i) {
    bool ok = true;
    for (int k = 0; k < 4; ++k) ok = ok && cv::norm(predicted[4 * i + k] - view[4 * i + k]) <= tolerance;
    if (ok) kept.push_back((*tags)[i]);
  }
  *tags = kept;
}

bool IsKalibrXJunction(const cv::Mat& grey, const Eigen::Vector2d& corner,
                       const Eigen::Vector2d& to_next, const Eigen::Vector2d& to_previous, double r,
                       int min_contrast) {
  const Eigen::Vector2d in = r * (to_next + to_previous).normalized();
  const Eigen::Vector2d across = r * (to_next - to_previous).normalized();
  const double dark[2] = {Bilinear(grey, corner.x() + in.x(), corner.y() + in.y()),
                          Bilinear(grey, corner.x() - in.x(), corner.y() - in.y())};
  const double light[2] = {Bilinear(grey, corner.x() + across.x(), corner.y() + across.y()),
                           Bilinear(grey, corner.x() - across.x(), corner.y() - across.y())};
  if (std::min({dark[0], dark[1], light[0], light[1]}) < 0) return false;  // outside the image
  return std::min(light[0], light[1]) - std::max(dark[0], dark[1]) >= min_contrast;
}

bool RefineSaddleCorner(const cv::Mat& grey, const Eigen::Vector2d& corner, int half_window_px,
                        double max_shift_px, Eigen::Vector2d* refined) {
  const int h = std::max(2, half_window_px);
  if (!(corner.x() >= h + 1 && corner.y() >= h + 1 && corner.x() < grey.cols - h - 2 &&
        corner.y() < grey.rows - h - 2)) {
    return false;
  }
  std::vector<cv::Point2f> points{cv::Point2f(static_cast<float>(corner.x()),
                                              static_cast<float>(corner.y()))};
  cv::cornerSubPix(grey, points, cv::Size(h, h), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001));
  *refined = Eigen::Vector2d(points[0].x, points[0].y);
  return refined->allFinite() && (*refined - corner).norm() <= max_shift_px;
}

cv::Mat KalibrTagMask(const cv::Mat& view_grey, const KalibrDetectorOptions& options) {
  const int up = std::max(1, options.upsample);
  cv::Mat big;
  cv::resize(view_grey, big, cv::Size(), up, up, cv::INTER_LINEAR);
  // Threshold halfway between the local darkest and brightest values; flat areas are white.
  const cv::Mat window = cv::getStructuringElement(
      cv::MORPH_RECT, cv::Size(options.threshold_window_px, options.threshold_window_px));
  cv::Mat lo, hi;
  cv::erode(big, lo, window);
  cv::dilate(big, hi, window);
  cv::Mat black(big.size(), CV_8U);
  for (int y = 0; y < big.rows; ++y) {
    const uchar *g = big.ptr<uchar>(y), *l = lo.ptr<uchar>(y), *u = hi.ptr<uchar>(y);
    uchar* b = black.ptr<uchar>(y);
    for (int x = 0; x < big.cols; ++x) {
      b[x] = (u[x] - l[x] >= options.min_contrast && 2 * g[x] < l[x] + u[x]) ? 255 : 0;
    }
  }
  // Break the tags' corner contacts with Kalibr's corner squares.
  if (options.separation_px > 0) {
    cv::erode(black, black, cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3)),
              cv::Point(-1, -1), options.separation_px);
  }
  return black;
}

std::vector<KalibrViewTag> DetectKalibrTagsInView(const cv::Mat& view_grey,
                                                  const KalibrDetectorOptions& options) {
  std::vector<KalibrViewTag> out;
  const int up = std::max(1, options.upsample);
  std::vector<int> seen;
  // Blur decides how wide the tag-to-corner-square necks are: more erosion passes for blurrier
  // (inner-ring) views; a tag found in an earlier pass is not read again.
  for (int pass = 0; pass < std::max(1, options.separation_passes); ++pass) {
  KalibrDetectorOptions pass_options = options;
  pass_options.separation_px = options.separation_px + pass;
  const cv::Mat black = KalibrTagMask(view_grey, pass_options);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(black, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  for (const auto& contour : contours) {
    std::array<cv::Point2f, 4> quad;
    if (!FitQuad(contour, options.min_side_px * up, &quad)) continue;
    // Enlarged pixel -> view pixel (pixel centres at integers in both).
    for (cv::Point2f& p : quad) p = (p + cv::Point2f(0.5f, 0.5f)) / up - cv::Point2f(0.5f, 0.5f);
    cv::Matx33d H;
    int id = DecodeQuad(view_grey, quad, options, &H);
    // A quad that does not read may still be a tag whose contour missed its corners: where a
    // neck to a corner square survived the erosion it pulls that corner out and tilts both sides
    // through it, and the thresholded border band's inner outline is a quad inside the tag; the
    // border or bit cells are then sampled off their middles. The tag's corners are X-junctions:
    // refined as saddles they are the tag's corners whatever the contour did, and the tag is read
    // once more from them. Not for quads inside a tag already read here (the same tag again), nor
    // for solid squares (Kalibr's corner squares), which no corner placement turns into a tag.
    if (id < 0 && options.refine_quad_before_decode &&
        !InsideAnyTag(out, 0.25f * (quad[0] + quad[1] + quad[2] + quad[3])) &&
        !DataAreaIsUniform(view_grey, quad, options.min_contrast)) {
      std::array<cv::Point2f, 4> refined;
      if (RefineQuadCorners(view_grey, quad, options.min_contrast, &refined)) {
        id = DecodeQuad(view_grey, refined, options, &H);
        if (id >= 0) quad = refined;
      }
    }
    if (id < 0 || std::count(seen.begin(), seen.end(), id)) continue;
    seen.push_back(id);
    KalibrViewTag tag;
    tag.tag_id = id;
    // k: 0 bottom-left, 1 bottom-right, 2 top-right, 3 top-left (in tag bits: y down).
    const double corner_bits[4][2] = {{0, kBits}, {kBits, kBits}, {kBits, 0}, {0, 0}};
    double side = 0;
    for (int k = 0; k < 4; ++k) {
      const cv::Vec3d p = H * cv::Vec3d(corner_bits[k][0], corner_bits[k][1], 1.0);
      tag.corners[k] = Eigen::Vector2d(p[0] / p[2], p[1] / p[2]);
      side += 0.25 * cv::norm(quad[k] - quad[(k + 1) % 4]);
    }
    bool ok = true;
    if (options.refine_in_view) {
      // The clean X-junction reaches 2 bits (the border) around the corner.
      const int half = static_cast<int>(std::lround(0.15 * side));
      for (int k = 0; k < 4 && ok; ++k) {
        ok = RefineSaddleCorner(view_grey, tag.corners[k], half, 0.1 * side, &tag.corners[k]);
      }
    }
    if (ok) out.push_back(tag);
  }
  }
  return out;
}

}  // namespace omni::detectors
