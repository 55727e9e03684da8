// Undistort / crop / resize / grey (image_pipeline.hpp).
#include "visnav/recorded/image_pipeline.hpp"

#include <cmath>
#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgproc.hpp>

namespace visnav::recorded {

namespace fs = std::filesystem;

std::string resolve_path(const std::string& path, const std::string& relative_to) {
  if (path.empty() || relative_to.empty() || fs::path(path).is_absolute()) return path;
  return (fs::path(relative_to) / path).lexically_normal().string();
}

std::string config_folder(const std::string& file_of_params) {
  if (file_of_params.empty() || file_of_params.rfind("--", 0) == 0) return {};
  std::error_code ec;
  if (!fs::is_regular_file(file_of_params, ec)) return {};
  return fs::path(file_of_params).parent_path().string();
}

Status ImageOptions::validate() const {
  if (!crop_px.empty()) {
    if (crop_px.size() != 4) return fail(ErrorCode::invalid_value, {{}, 0, "crop_px"}, "expected x;y;width;height (4 values), got " + std::to_string(crop_px.size()));
    if (crop_px[0] < 0 || crop_px[1] < 0 || crop_px[2] < 1 || crop_px[3] < 1)
      return fail(ErrorCode::out_of_range, {{}, 0, "crop_px"}, "x, y must be >= 0 and width, height >= 1");
  }
  if (!crop_rows.empty()) {
    if (crop_rows.size() != 2) return fail(ErrorCode::invalid_value, {{}, 0, "crop_rows"}, "expected first;last (2 fractions), got " + std::to_string(crop_rows.size()));
    if (!(crop_rows[0] >= 0.0 && crop_rows[1] <= 1.0 && crop_rows[0] < crop_rows[1]))
      return fail(ErrorCode::out_of_range, {{}, 0, "crop_rows"}, "need 0 <= first < last <= 1");
  }
  if (!crop_px.empty() && !crop_rows.empty())
    return Error{"keys 'crop_px' and 'crop_rows': give at most one of them", ErrorCode::inconsistent, {{}, 0, "crop_rows"}};
  return ok();
}

Result<ImagePipeline> ImagePipeline::create(const ImageOptions& options, const std::string& relative_to) {
  VISNAV_TRY(options.validate());
  ImagePipeline p;
  p.options_ = options;
  if (options.calibration_file.empty()) return p;
  p.calibration_path_ = resolve_path(options.calibration_file, relative_to);
  const std::string& path = p.calibration_path_;
  if (!fs::exists(path)) return fail(ErrorCode::not_found, {path, 0, "calibration_file"}, "no such file");
  try {
    cv::FileStorage fsr(path, cv::FileStorage::READ);
    if (!fsr.isOpened())
      return fail(ErrorCode::parse_error, {path, 0, "calibration_file"}, "cannot be read as an OpenCV YAML/XML file");
    fsr["camera_matrix"] >> p.camera_matrix_;
    fsr["distortion_coefficients"] >> p.distortion_;
    int w = 0;
    int h = 0;
    if (!fsr["image_width"].empty()) fsr["image_width"] >> w;
    if (!fsr["image_height"].empty()) fsr["image_height"] >> h;
    p.calibration_size_ = cv::Size(w, h);
  } catch (const cv::Exception& e) {
    return fail(ErrorCode::parse_error, {path, 0, "calibration_file"}, e.what());
  }
  if (p.camera_matrix_.empty()) return Error{path + ": key 'camera_matrix' is missing", ErrorCode::missing, {path, 0, "camera_matrix"}};
  if (p.camera_matrix_.rows != 3 || p.camera_matrix_.cols != 3)
    return Error{path + ": key 'camera_matrix' must be 3x3, got " +
                std::to_string(p.camera_matrix_.rows) + "x" + std::to_string(p.camera_matrix_.cols), ErrorCode::invalid_value, {path, 0, "camera_matrix"}};
  if (p.distortion_.empty())
    return Error{path + ": key 'distortion_coefficients' is missing", ErrorCode::missing, {path, 0, "distortion_coefficients"}};
  const int n = static_cast<int>(p.distortion_.total());
  if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14)
    return Error{path + ": key 'distortion_coefficients' must have 4, 5, 8, 12 or 14 values, got " +
                std::to_string(n), ErrorCode::invalid_value, {path, 0, "distortion_coefficients"}};
  p.camera_matrix_.convertTo(p.camera_matrix_, CV_64F);
  p.distortion_ = p.distortion_.reshape(1, 1);
  p.distortion_.convertTo(p.distortion_, CV_64F);
  return p;
}

bool ImagePipeline::identity() const {
  return camera_matrix_.empty() && options_.crop_px.empty() && options_.crop_rows.empty() &&
         options_.resize_width_px == 0 && options_.resize_height_px == 0 && !options_.grey;
}

Status ImagePipeline::apply(const cv::Mat& in, cv::Mat& out) {
  if (in.empty()) return fail(ErrorCode::invalid_value, "empty image");
  if (in.depth() != CV_8U || (in.channels() != 1 && in.channels() != 3 && in.channels() != 4))
    return fail(ErrorCode::invalid_value, "unsupported image type (need 8-bit grey, BGR or BGRA), got depth " + std::to_string(in.depth()) +
                " with " + std::to_string(in.channels()) + " channels");
  cv::Mat current = in;
  bool fresh = false;  // true once `current` is a buffer allocated here for this frame
  if (in.channels() == 4) {
    cv::cvtColor(in, work_, cv::COLOR_BGRA2BGR);
    current = work_;
  }
  if (!camera_matrix_.empty()) {
    if (calibration_size_.width > 0 && calibration_size_.height > 0 && current.size() != calibration_size_)
      return fail(ErrorCode::inconsistent, {calibration_path_, 0, "calibration_file"}, "calibration is for " + std::to_string(calibration_size_.width) + "x" +
                  std::to_string(calibration_size_.height) + " images, the frame is " + std::to_string(current.cols) +
                  "x" + std::to_string(current.rows));
    if (map_size_ != current.size()) {
      cv::initUndistortRectifyMap(camera_matrix_, distortion_, cv::Mat(), camera_matrix_, current.size(), CV_16SC2,
                                  map1_, map2_);
      map_size_ = current.size();
    }
    cv::Mat undistorted;
    cv::remap(current, undistorted, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    current = undistorted;
    fresh = true;
  }
  cv::Rect roi(0, 0, current.cols, current.rows);
  if (!options_.crop_px.empty()) {
    roi = cv::Rect(static_cast<int>(options_.crop_px[0]), static_cast<int>(options_.crop_px[1]),
                   static_cast<int>(options_.crop_px[2]), static_cast<int>(options_.crop_px[3]));
    if (roi.x + roi.width > current.cols || roi.y + roi.height > current.rows)
      return fail(ErrorCode::inconsistent, {{}, 0, "crop_px"}, "rectangle " + std::to_string(roi.x) + ";" + std::to_string(roi.y) + ";" +
                  std::to_string(roi.width) + ";" + std::to_string(roi.height) + " leaves the " +
                  std::to_string(current.cols) + "x" + std::to_string(current.rows) + " image");
  } else if (!options_.crop_rows.empty()) {
    const int r0 = static_cast<int>(std::lround(options_.crop_rows[0] * current.rows));
    const int r1 = static_cast<int>(std::lround(options_.crop_rows[1] * current.rows));
    if (r1 - r0 < 1) return fail(ErrorCode::inconsistent, {{}, 0, "crop_rows"}, "keeps no row of a " + std::to_string(current.rows) + "-row image");
    roi = cv::Rect(0, r0, current.cols, r1 - r0);
  }
  current = current(roi);
  int w = options_.resize_width_px;
  int h = options_.resize_height_px;
  if (w > 0 && h == 0) h = std::max(1, static_cast<int>(std::lround(static_cast<double>(current.rows) * w / current.cols)));
  if (h > 0 && w == 0) w = std::max(1, static_cast<int>(std::lround(static_cast<double>(current.cols) * h / current.rows)));
  if (w > 0 && (w != current.cols || h != current.rows)) {
    cv::Mat resized;
    const bool shrink = w < current.cols || h < current.rows;
    cv::resize(current, resized, cv::Size(w, h), 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
    current = resized;
    fresh = true;
  }
  if (options_.grey && current.channels() == 3) {
    cv::Mat grey;
    cv::cvtColor(current, grey, cv::COLOR_BGR2GRAY);
    current = grey;
    fresh = true;
  }
  // Hand over a buffer nobody else writes into.
  if (!fresh || !current.isContinuous())
    out = current.clone();
  else
    out = current;
  return ok();
}

}  // namespace visnav::recorded
