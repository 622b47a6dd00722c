#include "detectors/detect_image.h"

#include <utility>

#include "model/io/file_util.h"

namespace omni::detectors {

DetectorContext::DetectorContext(const RigParams& rig, std::vector<TargetSpec> target_specs,
                                 bool lips, const ViewOptions& view_options)
    : model(rig),
      layout(ComputeRingLayout(model)),
      views(MakeRingViews(model, view_options)),
      targets(std::move(target_specs)),
      use_lips(lips) {}

io::ImageDetections DetectImage(const cv::Mat& image, DetectorContext* ctx,
                                std::vector<std::string>* warnings) {
  const RigParams& rig = ctx->model.params();
  if (image.empty()) throw io::InputError("the image is empty or could not be decoded");
  if (image.cols != rig.image_width || image.rows != rig.image_height) {
    throw io::InputError("the image is " + std::to_string(image.cols) + "x" +
                         std::to_string(image.rows) + ", the model expects " +
                         std::to_string(rig.image_width) + "x" + std::to_string(rig.image_height));
  }
  io::ImageDetections out;
  out.width = image.cols;
  out.height = image.rows;
  const cv::Mat grey = ToGrey(image);
  RenderViews(grey, &ctx->views);
  out.corners = DetectChessboards(grey, ctx->views, ctx->model, ctx->targets, ctx->chessboard);
  // TODO(tags): DetectTagGrids (detectors/apriltag_detector.h) and DetectLips
  // (detectors/lip_detector.h) once they are in the library.
  if (ctx->use_lips && image.channels() < 3 && warnings) {
    warnings->push_back("grey image: the coloured lips cannot be detected");
  }
  return out;
}

}  // namespace omni::detectors
