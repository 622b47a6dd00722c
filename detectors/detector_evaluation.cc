#include "detectors/detector_evaluation.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <numeric>

#include "detectors/common/board_modulation.h"
#include "detectors/lips/lip_intrinsics.h"
#include "io/text_append.h"
#include "model/rig_model.h"

namespace omni::detectors {
namespace {

int RangeBin(double range_mm) {
  const double edges[] = {500, 1000, 2000};
  int b = 0;
  while (b < 3 && range_mm >= edges[b]) ++b;
  return b;
}
const char* kRangeNames[] = {"0.3-0.5 m", "0.5-1 m", "1-2 m", "2-4 m"};
const char* kKindNames[] = {"chessboard", "apriltag", "kalibr"};  // by TargetType

// The recall target applies to junctions resolved this far apart: corners whose nearest other
// corner of their target in their ring is at least kSpacedPx away (true pixels), and whole
// targets (one placement in one ring) whose junctions are kResolvedPx apart (the median over its
// corners of the nearest other corner).
constexpr double kSpacedPx = 4.0;
constexpr double kResolvedPx = 6.0;
constexpr double kMatchPx = 3.0;

double Mean(const std::vector<double>& v) {
  double mean = 0;
  for (double e : v) mean += e / std::max<size_t>(1, v.size());
  return mean;
}

}  // namespace

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

const char* DetectorEvaluation::CsvHeader() {
  return "image,target,kind,id,mirror,range_mm,u,v,true_u,true_v,guided,found,modulation\n";
}

std::vector<double> DetectorEvaluation::Modulations(const std::vector<TruthCorner>& truth) const {
  std::vector<double> modulation(truth.size() * 2, 1.0);
  // (placement, id) -> index, for each corner's lattice neighbours on the same board.
  std::map<std::pair<int, int>, size_t> index;
  for (size_t i = 0; i < truth.size(); ++i) index[{truth[i].placement, truth[i].id}] = i;
  for (size_t i = 0; i < truth.size(); ++i) {
    const TargetSpec& spec = targets_[truth[i].target];
    if (spec.type != TargetType::kChessboard) continue;
    const int row = truth[i].id / spec.cols, col = truth[i].id % spec.cols;
    for (int m = 1; m <= 2; ++m) {
      const double sigma = readability_.blur_sigma_px[m - 1];
      if (!truth[i].pixel[m - 1] || !(sigma > 0)) continue;
      // The local square side along each of the board's directions: the nearer visible neighbour
      // on that line (0: none visible).
      const auto side = [&](int dr, int dc) {
        double best = 0;
        for (int sign : {-1, 1}) {
          const int r = row + sign * dr, c = col + sign * dc;
          if (r < 0 || c < 0 || r >= spec.rows || c >= spec.cols) continue;
          const auto it = index.find({truth[i].placement, r * spec.cols + c});
          if (it == index.end() || !truth[it->second].pixel[m - 1]) continue;
          const double d = (*truth[it->second].pixel[m - 1] - *truth[i].pixel[m - 1]).norm();
          if (best == 0 || d < best) best = d;
        }
        return best;
      };
      double s1 = side(0, 1), s2 = side(1, 0);
      if (s1 == 0) s1 = s2;
      if (s2 == 0) s2 = s1;
      if (s1 > 0) modulation[2 * i + m - 1] = ChessboardModulation(s1, s2, sigma);
    }
  }
  return modulation;
}

std::vector<std::string> DetectorEvaluation::AddImage(const std::string& name,
                                                      const ImageObservations& det,
                                                      const std::vector<bool>& guided,
                                                      const std::vector<TruthCorner>& truth,
                                                      std::string* csv) {
  std::vector<std::string> lines;
  std::string line;
  const auto kind_of = [&](int target) { return static_cast<int>(targets_[target].type); };
  std::vector<bool> truth_found(truth.size() * 2, false);
  const std::vector<double> modulation = Modulations(truth);
  for (size_t k = 0; k < det.corners.size(); ++k) {
    const CornerObservation& o = det.corners[k];
    Bin* guided_bin = guided[k] ? &guided_by_kind_[{kind_of(o.target), MirrorIndex(o.mirror)}] : nullptr;
    // The nearest visible true corner in the same ring.
    const TrueCornerMatch match = NearestTrueCorner(truth, o.mirror, o.pixel);
    const double best = match.distance_px;
    const int best_i = match.corner ? static_cast<int>(match.corner - truth.data()) : -1;
    const double range = best_i >= 0 ? truth[best_i].point_in_cam.head<2>().norm() : 0;
    Bin& bin = bins_[{MirrorIndex(o.mirror), RangeBin(range)}];
    // Targets with the same rows x cols cannot be told apart in an image (the detector reports
    // the first): the target is right if its pattern is.
    const auto same_pattern = [&](int a, int b) {
      return targets_[a].rows == targets_[b].rows && targets_[a].cols == targets_[b].cols;
    };
    if (best_i < 0 || best > kMatchPx || truth[best_i].id != o.id ||
        !same_pattern(truth[best_i].target, o.target)) {
      ++bin.wrong;
      if (guided_bin) ++guided_bin->wrong;
      line.clear();
      io::AppendFormat(&line, "%s: wrong%s: target %d id %d mirror %d at (%.1f, %.1f): nearest truth "
             "target %d id %d at %.2f px", name.c_str(), guided_bin ? " (guided)" : "", o.target,
             o.id, MirrorIndex(o.mirror), o.pixel.x(), o.pixel.y(),
             best_i >= 0 ? truth[best_i].target : -1, best_i >= 0 ? truth[best_i].id : -1, best);
      lines.push_back(line);
      continue;
    }
    bin.errors.push_back(best);
    if (guided_bin) guided_bin->errors.push_back(best);
    if (csv) {
      const Eigen::Vector2d& t = *truth[best_i].pixel[MirrorIndex(o.mirror) - 1];
      io::AppendFormat(csv, "%s,%d,%s,%d,%d,%.1f,%.4f,%.4f,%.4f,%.4f,%d,1,%.4f\n", name.c_str(),
             o.target, kKindNames[kind_of(o.target)], o.id, MirrorIndex(o.mirror), range,
             o.pixel.x(), o.pixel.y(), t.x(), t.y(), guided_bin ? 1 : 0,
             modulation[2 * best_i + MirrorIndex(o.mirror) - 1]);
    }
    if (best > 0.5) {  // right id but far off: named, like wrong ids, to find the cause
      line.clear();
      io::AppendFormat(&line, "%s: off: target %d id %d mirror %d at (%.1f, %.1f): %.2f px from truth",
             name.c_str(), o.target, o.id, MirrorIndex(o.mirror), o.pixel.x(), o.pixel.y(), best);
      lines.push_back(line);
    }
    by_kind_[{kind_of(o.target), MirrorIndex(o.mirror)}].errors.push_back(best);
    truth_found[2 * best_i + MirrorIndex(o.mirror) - 1] = true;
  }
  // (target, mirror) -> visible, found, range, readable: to name the boards that were missed.
  std::map<std::pair<int, int>, std::array<double, 4>> boards;
  std::map<std::pair<int, int>, std::vector<double>> nearest_by_board;
  for (size_t i = 0; i < truth.size(); ++i) {
    for (int m = 1; m <= 2; ++m) {
      if (!truth[i].pixel[m - 1]) continue;
      const bool found = truth_found[2 * i + m - 1];
      const bool readable = modulation[2 * i + m - 1] >= readability_.min_modulation;
      Bin& bin = bins_[{m, RangeBin(truth[i].point_in_cam.head<2>().norm())}];
      ++bin.visible;
      if (found) ++bin.found;
      if (readable) ++bin.readable;
      if (readable && found) ++bin.readable_found;
      if (csv && !found) {  // a missed corner: its true pixel only
        const Eigen::Vector2d& t = *truth[i].pixel[m - 1];
        io::AppendFormat(csv, "%s,%d,%s,%d,%d,%.1f,,,%.4f,%.4f,0,0,%.4f\n", name.c_str(),
               truth[i].target, kKindNames[kind_of(truth[i].target)], truth[i].id, m,
               truth[i].point_in_cam.head<2>().norm(), t.x(), t.y(), modulation[2 * i + m - 1]);
      }
      Bin& kind = by_kind_[{kind_of(truth[i].target), m}];
      ++kind.visible;
      if (found) ++kind.found;
      if (readable) ++kind.readable;
      if (readable && found) ++kind.readable_found;
      double nearest = 1e9;
      for (size_t j = 0; j < truth.size(); ++j) {
        if (j != i && truth[j].target == truth[i].target && truth[j].pixel[m - 1]) {
          nearest = std::min(nearest, (*truth[j].pixel[m - 1] - *truth[i].pixel[m - 1]).norm());
        }
      }
      if (nearest >= kSpacedPx) {
        Bin& spaced = spaced_by_kind_[{kind_of(truth[i].target), m}];
        ++spaced.visible;
        if (found) ++spaced.found;
      }
      nearest_by_board[{truth[i].target, m}].push_back(nearest);
      auto& b = boards[{truth[i].target, m}];
      b[0] += 1;
      b[1] += found ? 1 : 0;
      b[2] = truth[i].point_in_cam.head<2>().norm();
      b[3] += readable ? 1 : 0;
    }
  }
  for (const auto& [key, b] : boards) {
    if (Percentile(nearest_by_board[key], 0.5) >= kResolvedPx) {
      resolved_by_ring_[key.second].visible += static_cast<int>(b[0]);
      resolved_by_ring_[key.second].found += static_cast<int>(b[1]);
    }
    if (b[1] < b[0]) {
      line.clear();
      io::AppendFormat(&line, "%s: missed: target %d ring %d at %.2f m: %.0f of %.0f visible corners found",
             name.c_str(), key.first, key.second, b[2] / 1000, b[1], b[0]);
      if (b[3] < b[0]) io::AppendFormat(&line, " (%.0f readable)", b[3]);
      lines.push_back(line);
    }
  }
  return lines;
}

std::string DetectorEvaluation::Tables() const {
  std::string out;
  io::AppendFormat(&out, "%-6s %-10s %8s %8s %8s %8s %8s %6s\n", "ring", "range", "visible", "found",
         "found%", "mean_px", "p99_px", "wrong");
  const auto row = [&](const std::string& ring, const char* range, const Bin& bin) {
    io::AppendFormat(&out, "%-6s %-10s %8d %8d %7.1f%% %8.4f %8.4f %6d\n", ring.c_str(), range, bin.visible,
           bin.found, 100.0 * bin.found / std::max(1, bin.visible), Mean(bin.errors),
           Percentile(bin.errors, 0.99), bin.wrong);
  };
  Bin all;
  for (int m = 1; m <= 2; ++m) {
    Bin ring;
    for (int b = 0; b < 4; ++b) {
      auto it = bins_.find({m, b});
      if (it == bins_.end()) continue;
      const Bin& bin = it->second;
      row(std::to_string(m), kRangeNames[b], bin);
      for (Bin* t : {&ring, &all}) {
        t->errors.insert(t->errors.end(), bin.errors.begin(), bin.errors.end());
        t->visible += bin.visible;
        t->found += bin.found;
        t->wrong += bin.wrong;
      }
    }
    row(std::to_string(m), "all", ring);
  }
  row("both", "all", all);
  // The same visible corners less those no detector can read (Readability): recall of those.
  io::AppendFormat(&out, "readable: chessboard modulation >= %.0f%% at blur sigma %.2f / %.2f raw px "
         "(rings 1 / 2):\n%-6s %-10s %8s %8s %8s %8s %8s\n", 100 * readability_.min_modulation,
         readability_.blur_sigma_px[0], readability_.blur_sigma_px[1], "ring", "kind", "visible",
         "readable", "found", "found%", "unread_f");
  const auto readable_row = [&](const std::string& ring, const char* what, const Bin& t) {
    // unread_f: corners found although not counted readable.
    io::AppendFormat(&out, "%-6s %-10s %8d %8d %8d %7.1f%% %8d\n", ring.c_str(), what, t.visible,
           t.readable, t.readable_found, 100.0 * t.readable_found / std::max(1, t.readable),
           t.found - t.readable_found);
  };
  for (int m : {1, 2, 0}) {
    Bin t;
    for (const auto& [key, bin] : bins_) {
      if (m != 0 && key.first != m) continue;
      t.visible += bin.visible;
      t.readable += bin.readable;
      t.readable_found += bin.readable_found;
      t.found += bin.found;
    }
    readable_row(m ? std::to_string(m) : "both", "all", t);
  }
  for (const auto& [key, bin] : by_kind_) readable_row(std::to_string(key.second), kKindNames[key.first], bin);
  // The same per kind of target (wrong ids are counted in the range table only).
  for (const auto& [key, bin] : by_kind_) {
    io::AppendFormat(&out, "%-6d %-10s %8d %8zu %7.1f%% %8.4f %8.4f\n", key.second, kKindNames[key.first],
           bin.visible, bin.errors.size(), 100.0 * bin.found / std::max(1, bin.visible),
           Mean(bin.errors), Percentile(bin.errors, 0.99));
  }
  io::AppendFormat(&out, "corners at least %.0f px from their target's other corners in the ring:\n",
         kSpacedPx);
  for (const auto& [key, bin] : spaced_by_kind_) {
    io::AppendFormat(&out, "%-6d %-10s %8d %8d %7.1f%%\n", key.second, kKindNames[key.first], bin.visible,
           bin.found, 100.0 * bin.found / std::max(1, bin.visible));
  }
  io::AppendFormat(&out, "targets whose junctions are at least %.0f px apart (median nearest) in the ring:\n",
         kResolvedPx);
  for (const auto& [ring, bin] : resolved_by_ring_) {
    io::AppendFormat(&out, "%-6d %-10s %8d %8d %7.1f%%\n", ring, "resolved", bin.visible, bin.found,
           100.0 * bin.found / std::max(1, bin.visible));
  }
  // Guided corners alone (guided_detection.h): how many, their error and wrong ids.
  io::AppendFormat(&out, "guided corners (across rings):\n%-6s %-10s %8s %8s %8s %6s\n", "ring", "kind",
         "found", "mean_px", "p99_px", "wrong");
  for (const auto& [key, bin] : guided_by_kind_) {
    io::AppendFormat(&out, "%-6d %-10s %8zu %8.4f %8.4f %6d\n", key.second, kKindNames[key.first],
           bin.errors.size(), Mean(bin.errors), Percentile(bin.errors, 0.99), bin.wrong);
  }
  return out;
}

std::string LipIntrinsicsAgainstTruth(const RigParams& truth, const RigParams& nominal,
                                      const std::vector<LipEdgeObservation>& edges, int n_images) {
  std::string out;
  const double f_true = 0.5 * (truth.camera[kFx] + truth.camera[kFy]);
  const Eigen::Vector2d pp(truth.camera[kCx], truth.camera[kCy]);
  const LipReferencePoints ref = LipReferencePointsOf(truth);
  struct Ref {
    const char* name;
    Eigen::Vector2d pixel;
  };
  const Ref refs[] = {{"axis1", ref.axis1},
                      {"axis2", ref.axis2},
                      {"lip1_centre", ref.lip1_centre},
                      {"lip2_centre_in_reflex", ref.lip2_centre_in_reflex},
                      {"axis2_in_reflex", ref.axis2_in_reflex}};
  io::AppendFormat(&out, "lips (%d images, %zu labelled edges): true f %.3f pp (%.3f, %.3f); nominal pp "
         "(%.3f, %.3f)\n", n_images, edges.size(), f_true, pp.x(), pp.y(), nominal.camera[kCx],
         nominal.camera[kCy]);
  for (const Ref& r : refs) {
    io::AppendFormat(&out, "lips ref %-22s (%.3f, %.3f), minus true pp (%+.3f, %+.3f) = %.3f px\n", r.name,
           r.pixel.x(), r.pixel.y(), r.pixel.x() - pp.x(), r.pixel.y() - pp.y(),
           (r.pixel - pp).norm());
  }
  RigParams nominal_true_lens = nominal;
  nominal_true_lens.distortion = truth.distortion;
  struct Fit {
    const char* name;
    const RigParams* prior;
    int mirror;  // 0: all edges
  };
  const Fit fits[] = {{"all", &nominal, 0},
                      {"mirror1_edges", &nominal, 1},
                      {"mirror2_edges", &nominal, 2},
                      {"all_true_lens", &nominal_true_lens, 0}};
  for (const Fit& fit : fits) {
    std::vector<LipEdgeObservation> used;
    for (const LipEdgeObservation& e : edges) {
      if (fit.mirror == 0 || MirrorIndex(e.mirror) == fit.mirror) used.push_back(e);
    }
    const auto est = InitialIntrinsicsFromLips(used, RigModel(*fit.prior));
    if (!est) {
      io::AppendFormat(&out, "lips fit %-14s: failed (%zu edges)\n", fit.name, used.size());
      continue;
    }
    const Eigen::Vector2d c(est->cx, est->cy);
    io::AppendFormat(&out, "lips fit %-14s: f %.3f (%+.3f%%) pp (%.3f, %.3f) rms %.3f px, %d points; "
           "minus true pp (%+.3f, %+.3f) = %.3f px", fit.name, est->f, 100 * (est->f / f_true - 1),
           c.x(), c.y(), est->rms_px, est->n_points, c.x() - pp.x(), c.y() - pp.y(),
           (c - pp).norm());
    for (const Ref& r : refs) io::AppendFormat(&out, "; %s %.3f", r.name, (c - r.pixel).norm());
    out += " px\n";
  }
  return out;
}

std::vector<std::string> DetectAndEvaluate(const cv::Mat& raw, const std::string& name,
                                           const std::vector<TruthCorner>& truth,
                                           DetectorContext* ctx, DetectorEvaluation* evaluation,
                                           DetectionRun* run, std::string* csv_rows) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  std::vector<bool> guided;
  const ImageObservations det = DetectImage(raw, ctx, nullptr, &guided);
  for (const RingView& v : ctx->views) {
    if (v.blur_sigma) run->view_blur[MirrorIndex(v.mirror) - 1].push_back(*v.blur_sigma);
  }
  run->cpu_ms.push_back(1000.0 * (std::clock() - c0) / CLOCKS_PER_SEC);
  run->times_ms.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  if (!det.lips.empty()) {
    ++run->lip_images;
    run->lips.insert(run->lips.end(), det.lips.begin(), det.lips.end());
  }
  std::vector<std::string> lines = evaluation->AddImage(name, det, guided, truth, csv_rows);
  std::string last;
  io::AppendFormat(&last, "%s: %zu corners in %.1f ms", name.c_str(), det.corners.size(),
                   run->times_ms.back());
  lines.push_back(last);
  return lines;
}

std::string DetectionRunReport(const DetectionRun& run, const DetectorContext& ctx,
                               const DetectorEvaluation& evaluation, const RigParams& rig,
                               const RigParams& nominal, double context_ms) {
  std::string out;
  io::AppendFormat(&out, "views and layout built once in %.0f ms\n", context_ms);
  for (int ring = 0; ring < 2; ++ring) {
    for (const RingView& v : ctx.views) {
      if (MirrorIndex(v.mirror) != ring + 1) continue;
      io::AppendFormat(&out, "ring %d views: %d x %d px, f %.0f px/rad, measured blur sigma "
                       "median %.2f view px\n", ring + 1, v.width, v.height, v.f,
                       Percentile(run.view_blur[ring], 0.5));
      break;
    }
  }
  out += evaluation.Tables();
  if (!run.times_ms.empty()) {
    const auto sum = [](const std::vector<double>& v) {
      return std::accumulate(v.begin(), v.end(), 0.0);
    };
    io::AppendFormat(&out, "time per %dx%d image on one core: mean %.1f ms, max %.1f ms (%zu "
                     "images)\n", rig.image_width, rig.image_height,
                     sum(run.times_ms) / run.times_ms.size(), Percentile(run.times_ms, 1.0),
                     run.times_ms.size());
    io::AppendFormat(&out, "CPU time per image (independent of other load): mean %.1f ms, max "
                     "%.1f ms\n", sum(run.cpu_ms) / run.cpu_ms.size(), Percentile(run.cpu_ms, 1.0));
  }
  if (!run.lips.empty()) out += LipIntrinsicsAgainstTruth(rig, nominal, run.lips, run.lip_images);
  return out;
}

}  // namespace omni::detectors
