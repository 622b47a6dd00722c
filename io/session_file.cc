#include "io/session_file.h"

#include <glob.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <sstream>

#include "io/yaml_reader.h"
#include "model/rig_parameters.h"

namespace omni::io {
namespace {

namespace fs = std::filesystem;

constexpr char kFormatPrefix[] = "omnistereo-session/";
constexpr int kFormatMajor = 1;

std::string Resolve(const std::string& base_dir, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

// `images:` may be left out where the detections are given (calibrate, report with
// --detections); detect then says it needs them (detectors/detect_session.h).
std::vector<std::string> ExpandImages(const Reader& in, const YAML::Node& root,
                                      const std::string& base_dir) {
  if (!root["images"].IsDefined() || root["images"].IsNull()) return {};
  const std::vector<std::string> patterns = in.Strings(root, "", "images");
  if (patterns.empty()) in.Fail("images", "expected at least one image path or glob", "an empty list");
  std::vector<std::string> images;
  for (std::size_t i = 0; i < patterns.size(); ++i) {
    const std::string key = "images[" + std::to_string(i) + "]";
    const std::string pattern = Resolve(base_dir, patterns[i]);
    const std::vector<std::string> found = ExpandImagePattern(pattern);
    if (found.empty()) in.Fail(key, "expected files matching '" + pattern + "'", "none");
    images.insert(images.end(), found.begin(), found.end());
  }
  return images;
}

TargetSpec ReadTarget(const Reader& in, const YAML::Node& node, const std::string& key) {
  if (!IsMap(node)) in.Fail(key, "expected a map {type: ..., rows: ..., ...}", Describe(node));
  TargetSpec t;
  const std::string type = in.String(node, key, "type");
  if (!ParseTargetType(type, &t.type)) {
    in.Fail(Join(key, "type"), "expected chessboard, apriltag_grid or kalibr_aprilgrid",
            Describe(node["type"]));
  }
  if (t.type == TargetType::kChessboard) {
    t.rows = in.Integer(node, key, "rows", 2);
    t.cols = in.Integer(node, key, "cols", 2);
    t.square_mm = in.Positive(node, key, "square");
    return t;
  }
  t.rows = in.Integer(node, key, "rows", 1);
  t.cols = in.Integer(node, key, "cols", 1);
  t.tag_size_mm = in.Positive(node, key, "tag_size");
  t.spacing = node["spacing"].IsDefined() ? in.Number(node, key, "spacing") : 0.3;
  if (!(t.spacing > 0)) in.Fail(Join(key, "spacing"), "expected a gap/tag_size ratio > 0", Describe(node["spacing"]));
  t.first_id = node["first_id"].IsDefined() ? in.Integer(node, key, "first_id", 0) : 0;
  if (node["family"].IsDefined()) t.family = in.String(node, key, "family");
  if (t.family != "tag36h11") in.Fail(Join(key, "family"), "expected tag36h11", Describe(node["family"]));
  if (t.first_id + t.rows * t.cols > 587) {
    in.Fail(key, "expected first_id + rows*cols <= 587 (tag36h11 has 587 tags)",
            std::to_string(t.first_id + t.rows * t.cols));
  }
  return t;
}

void ReadSolver(const Reader& in, const YAML::Node& node, SolverOptions* s) {
  const std::string key = "solver";
  if (!IsMap(node)) in.Fail(key, "expected a map of solver options", Describe(node));
  if (node["max_iterations"].IsDefined()) s->max_iterations = in.Integer(node, key, "max_iterations", 1);
  if (node["loss"].IsDefined()) {
    s->loss = in.String(node, key, "loss");
    if (s->loss != "huber" && s->loss != "cauchy" && s->loss != "none") {
      in.Fail(Join(key, "loss"), "expected huber, cauchy or none", Describe(node["loss"]));
    }
  }
  if (node["loss_scale_px"].IsDefined()) s->loss_scale_px = in.Positive(node, key, "loss_scale_px");
  if (node["outlier_px"].IsDefined()) s->outlier_px = in.Positive(node, key, "outlier_px");
  if (node["threads"].IsDefined()) s->threads = in.Integer(node, key, "threads", 1);
}

// `path` (absolute, or relative to the working folder) as the file at base_dir will read it:
// relative to base_dir where it lies under it, else absolute. (A path relative to the working
// folder written as it was would be read against base_dir: `init --images 'render/*.jpg' --out
// work/session.yaml` wrote images that detect could not find.)
std::string Relative(const std::string& path, const std::string& base_dir) {
  if (base_dir.empty()) return path;
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec).lexically_normal();
  const fs::path base = fs::absolute(base_dir, ec).lexically_normal();
  if (ec) return path;
  const fs::path rel = absolute.lexically_relative(base);
  if (rel.empty() || *rel.begin() == "..") return absolute.string();
  return rel.string();
}

std::string Quote(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

const std::vector<std::string>& EstimableGroups() {
  // The default ones first, then the mirror shapes (model/rig_parameters.h).
  static const std::vector<std::string> groups = [] {
    std::vector<std::string> out = DefaultEstimateBlocks();
    for (const RigBlock& b : kRigBlocks) {
      if (std::find(out.begin(), out.end(), b.name) == out.end()) out.push_back(b.name);
    }
    return out;
  }();
  return groups;
}

std::vector<std::string> ExpandImagePattern(const std::string& pattern) {
  if (pattern.find_first_of("*?[") == std::string::npos) return {pattern};
  glob_t matches{};
  const int rc = ::glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<std::string> found;
  if (rc == 0) {
    for (std::size_t k = 0; k < matches.gl_pathc; ++k) found.push_back(matches.gl_pathv[k]);
  }
  globfree(&matches);
  std::sort(found.begin(), found.end());
  return found;
}

std::vector<TargetSpec> ParseTargetList(const std::string& text, const std::string& what) {
  const Reader in(what);
  YAML::Node node;
  try {
    node = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(what + ": expected a YAML list of targets, got '" + text + "' (" + e.msg + ")");
  }
  std::vector<TargetSpec> targets;
  if (IsMap(node)) {
    targets.push_back(ReadTarget(in, node, "[0]"));
  } else if (IsSequence(node)) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      targets.push_back(ReadTarget(in, node[i], "[" + std::to_string(i) + "]"));
    }
  } else if (node.IsDefined() && !node.IsNull()) {
    throw InputError(what + ": expected a YAML list of targets, got " + Describe(node));
  }
  return targets;
}

namespace {

// The camera's image keys: the Bayer pattern of raw frames and the tone curve.
void ReadImageKeys(const Reader& in, const YAML::Node& root, Session* session) {
  if (root["bayer"].IsDefined()) {
    const YAML::Node bayer = root["bayer"];
    const auto pattern = ParseBayerPattern(bayer.IsScalar() ? bayer.Scalar() : "?");
    if (!pattern) in.Fail("bayer", "expected RGGB, BGGR, GRBG, GBRG or none", Describe(bayer));
    session->bayer = *pattern;
    if (session->bayer != BayerPattern::kNone) session->tone = ToneCurve::kLinear;
  }
  if (root["tone"].IsDefined()) {
    const YAML::Node tone = root["tone"];
    const auto curve = ParseToneCurve(tone.IsScalar() ? tone.Scalar() : "?");
    if (!curve) in.Fail("tone", "expected srgb (colour cameras, JPEG) or linear (raw frames, gamma off)", Describe(tone));
    session->tone = *curve;
  }
}

// `estimate`: the parameter groups (blocks) to refine, each once ([]: none, the model scored);
// the table's default without it.
void ReadEstimate(const Reader& in, const YAML::Node& root, Session* session) {
  if (root["estimate"].IsDefined()) {
    // An empty list scores the model on the session's photos: only the targets' poses solved.
    session->estimate = in.Strings(root, "", "estimate");
    std::set<std::string> seen;
    for (std::size_t i = 0; i < session->estimate.size(); ++i) {
      const std::string& g = session->estimate[i];
      const auto& known = EstimableGroups();
      if (std::find(known.begin(), known.end(), g) == known.end()) {
        std::string choices;
        for (const auto& k : known) choices += (choices.empty() ? "" : ", ") + k;
        in.Fail("estimate[" + std::to_string(i) + "]", "expected one of " + choices,
                Describe(root["estimate"][i]));
      }
      if (!seen.insert(g).second) in.Fail("estimate[" + std::to_string(i) + "]", "expected each group once", "'" + g + "' twice");
    }
  } else {
    session->estimate = DefaultEstimateBlocks();
  }

}

// `priors`: a manufacturing prior per block that may take one (RigBlock::prior).
void ReadPriors(const Reader& in, const YAML::Node& root, Session* session) {
  if (root["priors"].IsDefined()) {
    const YAML::Node priors = root["priors"];
    // The blocks a prior may be given (model/rig_parameters.h: RigBlock::prior).
    std::vector<std::string> prior_blocks;
    for (const RigBlock& b : kRigBlocks) {
      if (b.prior) prior_blocks.push_back(b.name);
    }
    std::string choices;
    for (size_t i = 0; i < prior_blocks.size(); ++i) {
      choices += (i == 0 ? "" : i + 1 == prior_blocks.size() ? " or " : ", ") + prior_blocks[i];
    }
    if (!IsMap(priors)) {
      in.Fail("priors", "expected a map {" + prior_blocks[0] + ": {...}}", Describe(priors));
    }
    for (const auto& item : priors) {
      if (!item.first.IsScalar()) in.Fail("priors", "expected names as keys", Describe(item.first));
      const std::string name = item.first.Scalar();
      const std::string key = "priors." + name;
      if (std::find(prior_blocks.begin(), prior_blocks.end(), name) == prior_blocks.end()) {
        in.Fail(key, "expected " + choices, "'" + name + "'");
      }
      if (!IsMap(item.second)) in.Fail(key, "expected {sigma_c: mm, sigma_k: ...}", Describe(item.second));
      ShapePrior prior;
      prior.sigma_c = in.Positive(item.second, key, "sigma_c");
      prior.sigma_k = in.Positive(item.second, key, "sigma_k");
      session->priors[name] = prior;
    }
  }
}

// `consider`: an assumed sigma for held parameters a session may consider
// (RigParameter::considerable).
void ReadConsider(const Reader& in, const YAML::Node& root, Session* session) {
  if (root["consider"].IsDefined()) {
    const YAML::Node consider = root["consider"];
    if (!IsMap(consider)) {
      const std::string example = ParametersWithRole(SolveRole::kTangential).front()->name;
      in.Fail("consider", "expected a map {" + example + ": sigma, ...}", Describe(consider));
    }
    session->consider.emplace();
    for (const auto& item : consider) {
      if (!item.first.IsScalar()) in.Fail("consider", "expected names as keys", Describe(item.first));
      const std::string name = item.first.Scalar();
      const std::string key = "consider." + name;
      const RigParameter* p = FindRigParameter(name);
      if (!p || !p->considerable || name != p->name) {
        std::string choices;
        for (const RigParameter& c : RigParameterTable()) {
          if (c.considerable) choices += (choices.empty() ? "" : ", ") + std::string(c.name);
        }
        in.Fail(key, "expected one of " + choices, "'" + name + "'");
      }
      const double sigma = in.Number(item.second, key);
      if (!(sigma >= 0)) in.Fail(key, "expected a sigma >= 0", Describe(item.second));
      (*session->consider)[name] = sigma;
    }
  }
}

}  // namespace

Session ReadSessionFile(const std::string& path) {
  const YAML::Node root = LoadYamlFile(path, "session file");
  const Reader in(path);
  if (!IsMap(root)) in.Fail("format", "expected a YAML map starting with 'format:'", Describe(root));
  CheckFormat(in, root, kFormatPrefix, kFormatMajor);
  const std::string base_dir = fs::path(path).parent_path().string();

  Session session;
  session.path = path;
  session.model_path = Resolve(base_dir, in.String(root, "", "model"));
  session.images = ExpandImages(in, root, base_dir);

  // An empty list is a lips-only session: `detect` checks a new camera's intrinsics from the lips
  // alone; `calibrate` needs targets and says so.
  const YAML::Node targets = root["targets"];
  if (!IsSequence(targets)) {
    in.Fail("targets", "expected a list of targets ([] for a lips-only session)", Describe(targets));
  }
  for (std::size_t i = 0; i < targets.size(); ++i) {
    session.targets.push_back(ReadTarget(in, targets[i], "targets[" + std::to_string(i) + "]"));
  }
  if (root["lips"].IsDefined()) session.use_lips = in.Bool(root, "", "lips");
  if (root["profile"].IsDefined()) {
    session.profile = in.String(root, "", "profile");
    if (session.profile != "auto" && session.profile != "free" && session.profile != "hold" &&
        session.profile != "off") {
      in.Fail("profile", "expected auto, free, hold or off", Describe(root["profile"]));
    }
  }
  if (root["noncentral"].IsDefined()) {
    session.noncentral = in.String(root, "", "noncentral");
    if (session.noncentral != "auto" && session.noncentral != "free") {
      in.Fail("noncentral", "expected auto or free", Describe(root["noncentral"]));
    }
  }
  if (root["profile_sigma_mm"].IsDefined()) {
    session.profile_sigma_mm = in.Positive(root, "", "profile_sigma_mm");
  }
  ReadImageKeys(in, root, &session);
  ReadEstimate(in, root, &session);
  ReadPriors(in, root, &session);
  ReadConsider(in, root, &session);
  if (root["solver"].IsDefined()) ReadSolver(in, root["solver"], &session.solver);
  return session;
}

std::string TargetEntryText(const TargetSpec& t) {
  std::ostringstream out;
  out << "{type: " << TargetTypeName(t.type) << ", rows: " << t.rows << ", cols: " << t.cols;
  if (t.type == TargetType::kChessboard) {
    out << ", square: " << FormatDouble(t.square_mm) << "}";
  } else {
    out << ", tag_size: " << FormatDouble(t.tag_size_mm) << ", spacing: "
        << FormatDouble(t.spacing) << ", first_id: " << t.first_id;
    if (t.type == TargetType::kAprilTagGrid) out << ", family: " << t.family;
    out << "}";
  }
  return out.str();
}

std::string SessionText(const Session& session, const std::string& base_dir) {
  std::ostringstream out;
  out << "format: omnistereo-session/1\n";
  out << "model: " << Quote(Relative(session.model_path, base_dir)) << "\n";
  if (!session.images.empty()) out << "images:\n";
  for (const auto& image : session.images) out << "  - " << Quote(Relative(image, base_dir)) << "\n";
  out << "targets:" << (session.targets.empty() ? " []" : "") << "\n";
  for (const TargetSpec& t : session.targets) out << "  - " << TargetEntryText(t) << "\n";
  out << "lips: " << (session.use_lips ? "true" : "false") << "\n";
  out << "tone: " << ToneCurveName(session.tone) << "   # how the images encode light: srgb or linear\n";
  if (session.bayer != BayerPattern::kNone) {
    out << "bayer: " << BayerName(session.bayer) << "   # raw frames, demosaiced when read\n";
  }
  out << "estimate: [";
  for (std::size_t i = 0; i < session.estimate.size(); ++i) {
    out << (i ? ", " : "") << session.estimate[i];
  }
  out << "]\n";
  if (!session.profile.empty()) out << "profile: " << session.profile << "\n";
  if (!session.noncentral.empty()) out << "noncentral: " << session.noncentral << "\n";
  if (session.profile_sigma_mm > 0) {
    out << "profile_sigma_mm: " << FormatDouble(session.profile_sigma_mm) << "\n";
  }
  if (session.consider) {
    out << "consider: {";
    const char* sep = "";
    for (const auto& [name, sigma] : *session.consider) {
      out << sep << name << ": " << FormatDouble(sigma);
      sep = ", ";
    }
    out << "}\n";
  }
  if (!session.priors.empty()) {
    out << "priors:\n";
    for (const auto& [name, p] : session.priors) {
      out << "  " << name << ": {sigma_c: " << FormatDouble(p.sigma_c)
          << ", sigma_k: " << FormatDouble(p.sigma_k) << "}\n";
    }
  }
  const SolverOptions& s = session.solver;
  out << "solver: {max_iterations: " << s.max_iterations << ", loss: " << s.loss
      << ", loss_scale_px: " << FormatDouble(s.loss_scale_px)
      << ", outlier_px: " << FormatDouble(s.outlier_px) << ", threads: " << s.threads << "}\n";
  return out.str();
}

}  // namespace omni::io
