#include "cmd_pathseg.hpp"

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "visnav/path_following/params.hpp"
#include "visnav/path_following/path_follower.hpp"
#include "visnav/path_following/stages.hpp"

namespace visnav::path_following {

int run_pathseg(int argc, char** argv, HostServices& /*host*/) {
  std::vector<std::string> args(argv + (argc > 0 ? 1 : 0), argv + argc);
  std::string image_path, draw_path;
  ConfigNode overrides = ConfigNode::make_map(SourceLocation{"command line", 0});
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      std::cout << kPathsegUsage;
      return 0;
    }
    if (a == "--draw" || a == "--set") {
      if (i + 1 >= args.size()) {
        std::cerr << "visnav pathseg: " << a << " needs a value\n" << kPathsegUsage;
        return 2;
      }
      const std::string& value = args[++i];
      if (a == "--draw") {
        draw_path = value;
      } else {
        const auto eq = value.find('=');
        if (eq == std::string::npos || eq == 0) {
          std::cerr << "visnav pathseg: --set expects key=value, got '" << value << "'\n";
          return 2;
        }
        overrides.set(value.substr(0, eq),
                      ConfigNode::make_scalar(value.substr(eq + 1), SourceLocation{"--set " + value, 0}));
      }
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "visnav pathseg: unknown option '" << a << "'\n" << kPathsegUsage;
      return 2;
    } else if (image_path.empty()) {
      image_path = a;
    } else {
      std::cerr << "visnav pathseg: more than one image given ('" << image_path << "', '" << a << "')\n";
      return 2;
    }
  }
  if (image_path.empty()) {
    std::cerr << "visnav pathseg: no image given\n" << kPathsegUsage;
    return 2;
  }

  auto params = PathFollowerParams::schema().parse(overrides);
  if (!params) {
    std::cerr << "visnav pathseg: " << params.error().message << "\n";
    return 1;
  }
  const cv::Mat image = cv::imread(image_path, cv::IMREAD_COLOR);
  if (image.empty()) {
    std::cerr << "visnav pathseg: cannot read image '" << image_path << "'\n";
    return 1;
  }
  auto follower = PathFollower::create(*params);
  if (!follower) {
    std::cerr << "visnav pathseg: " << follower.error().message << "\n";
    return 1;
  }
  PathEstimate estimate;
  auto processed = follower->process(image, estimate);
  if (!processed) {
    std::cerr << "visnav pathseg: " << image_path << ": " << processed.error().message << "\n";
    return 1;
  }
  std::printf("image: %s (%dx%d)\n", image_path.c_str(), image.cols, image.rows);
  std::printf("status: %s\n", std::string(to_string(estimate.status)).c_str());
  std::printf("horizon_row_px: %d (%s, contrast %.1f)\n", estimate.horizon.row_px,
              estimate.horizon.detected ? "detected" : "configured/fallback", estimate.horizon.contrast);
  std::printf("segments: %d\nreference_models: %d\n", estimate.segments, estimate.reference_models);
  std::printf("area_share: %.4f\nmean_offset: %+.4f\n", estimate.area_share, estimate.mean_offset);
  std::printf("v_mps: %.4f\nomega_radps: %+.4f\n", estimate.command.linear_mps, estimate.command.angular_radps);
  if (!draw_path.empty()) {
    const cv::Mat stages = render_stages(image, estimate, follower->stages(), follower->params());
    bool written = false;
    try {
      written = cv::imwrite(draw_path, stages);
    } catch (const cv::Exception& e) {
      std::cerr << "visnav pathseg: cannot write '" << draw_path << "': " << e.what() << "\n";
      return 1;
    }
    if (!written) {
      std::cerr << "visnav pathseg: cannot write '" << draw_path << "' (unknown extension or unwritable)\n";
      return 1;
    }
    std::printf("stages: %s\n", draw_path.c_str());
  }
  return 0;
}

}  // namespace visnav::path_following
