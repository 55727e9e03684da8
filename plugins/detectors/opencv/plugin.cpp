// Detector plugin: OpenCV detectors — orb, sift, akaze, brisk (OpenCV detector + descriptor) and
// agast_brief, fast_brief, gftt_brief (OpenCV detector + this project's BRIEF-256), all with the
// adaptive threshold and the upright option of plugins/detectors/common.
#include "visnav/detectors/detector_types.hpp"
#include "visnav/plugin.hpp"

namespace {

namespace d = visnav::detectors;

const visnav::TypeEntry kTypes[] = {
    visnav::make_type<d::OrbDetector>("orb", "OpenCV ORB (oriented FAST + rotated BRIEF), adaptive FAST threshold"),
    visnav::make_type<d::AgastBriefDetector>("agast_brief", "OpenCV AGAST corners + BRIEF-256, adaptive threshold"),
    visnav::make_type<d::FastBriefDetector>("fast_brief", "OpenCV FAST corners + BRIEF-256, adaptive threshold"),
    visnav::make_type<d::GfttBriefDetector>("gftt_brief", "OpenCV good-features-to-track + BRIEF-256, adaptive quality"),
    visnav::make_type<d::SiftDetector>("sift", "OpenCV SIFT (float descriptor, L2), adaptive contrast threshold"),
    visnav::make_type<d::AkazeDetector>("akaze", "OpenCV AKAZE (MLDB binary descriptor), adaptive threshold"),
    visnav::make_type<d::BriskDetector>("brisk", "OpenCV BRISK (always oriented), adaptive threshold"),
};

}  // namespace

VISNAV_PLUGIN({.name = "detectors_opencv",
               .version = "1.0",
               .description = "OpenCV detectors (ORB, SIFT, AKAZE, BRISK, AGAST/FAST/GFTT + BRIEF)",
               .types = kTypes})
