// visnav recorded-run helpers — the image pipeline every file/device camera applies to a raw
// image: undistort → crop → resize → grey.
//
//  * Undistortion: `calibration_file` is an OpenCV FileStorage file (YAML/XML) with
//    `camera_matrix` (3x3) and `distortion_coefficients` (4, 5, 8, 12 or 14 values), optionally
//    `image_width`/`image_height` (the size the calibration was made at; a frame of another size
//    is an error naming the file). The camera matrix is kept (no new optimal matrix), so the
//    undistorted image has the same size and focal length. Remap tables are built once for the
//    first frame size.
//  * Crop: `crop_px` = x;y;width;height in pixels of the undistorted image, or
//    `crop_rows` = first;last fraction of the height to keep (e.g. 0;0.5 = the top half).
//    A crop that leaves the image is an error naming the frame size.
//  * Resize: `resize_width_px`/`resize_height_px` (0 = keep; one of them 0 keeps the aspect ratio);
//    INTER_AREA when shrinking, INTER_LINEAR when enlarging.
//  * `grey`: deliver CV_8UC1.
// Input must be 8-bit, 1, 3 or 4 channels (4 is converted to BGR); anything else is an error.
// Thread-safety: one thread per pipeline (apply() reuses the remap tables and a work buffer).
#pragma once

#include <concepts>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "visnav/params.hpp"
#include "visnav/result.hpp"

namespace visnav::recorded {

struct ImageOptions {
  std::string calibration_file;       ///< "" = no undistortion; relative to the config file's folder
  std::vector<double> crop_px;        ///< empty, or x;y;width;height (px)
  std::vector<double> crop_rows;      ///< empty, or first;last as fractions of the height in [0, 1]
  int resize_width_px = 0;            ///< 0 = keep
  int resize_height_px = 0;           ///< 0 = keep
  bool grey = false;

  [[nodiscard]] Status validate() const;
};

/// Undistort/crop/resize/grey, built from validated options.
class ImagePipeline {
 public:
  /// Loads the calibration (if any). `relative_to`: folder for a relative calibration path.
  /// Errors name the calibration file and the missing/invalid key.
  [[nodiscard]] static Result<ImagePipeline> create(const ImageOptions& options, const std::string& relative_to = {});

  /// Processes `in` into a freshly allocated `out` (safe to hand over in a Frame).
  [[nodiscard]] Status apply(const cv::Mat& in, cv::Mat& out);
  /// True when apply() changes nothing (no calibration, crop, resize or grey).
  [[nodiscard]] bool identity() const;
  [[nodiscard]] const ImageOptions& options() const { return options_; }

 private:
  ImageOptions options_;
  std::string calibration_path_;
  cv::Mat camera_matrix_;
  cv::Mat distortion_;
  cv::Size calibration_size_{0, 0};
  cv::Size map_size_{0, 0};
  cv::Mat map1_, map2_;
  cv::Mat work_;
};

/// Resolves `path` against `relative_to` (a folder) unless it is absolute or `relative_to` is empty.
[[nodiscard]] std::string resolve_path(const std::string& path, const std::string& relative_to);
/// The folder of the config file a params node came from ("" for built-in/CLI values).
[[nodiscard]] std::string config_folder(const std::string& file_of_params);

/// Adds the image keys (the ImageOptions members) to a camera's schema, so every camera documents
/// them the same way. A camera's params struct derives from ImageOptions, which gives it those
/// members and the image part of validation (call ImageOptions::validate() from its own
/// validate()); ImagePipeline::create() takes the struct as it is:
///   struct VideoParams : ImageOptions { std::string file; ...
///     Status validate() const { if (file.empty()) return fail(...); return ImageOptions::validate(); } };
template <typename P>
  requires std::derived_from<P, ImageOptions>
ParamSchema<P>& add_image_fields(ParamSchema<P>& s) {
  // Explicit field types: &P::grey names ImageOptions::grey, converted to a member of P.
  s.template field<std::string>("calibration_file", &P::calibration_file,
                                "OpenCV YAML/XML with camera_matrix and distortion_coefficients; frames are undistorted; '' = off")
      .template field<std::vector<double>>("crop_px", &P::crop_px, "crop x;y;width;height, px of the undistorted image; empty = none")
      .template field<std::vector<double>>("crop_rows", &P::crop_rows,
                                           "keep rows first;last as fractions of the height (0;0.5 = top half); empty = all")
      .template field<int>("resize_width_px", &P::resize_width_px, "output width, px; 0 = keep (or keep the aspect ratio)").range(0, 16384)
      .template field<int>("resize_height_px", &P::resize_height_px, "output height, px; 0 = keep (or keep the aspect ratio)").range(0, 16384)
      .template field<bool>("grey", &P::grey, "deliver 8-bit grey frames (CV_8UC1)");
  return s;
}

}  // namespace visnav::recorded
