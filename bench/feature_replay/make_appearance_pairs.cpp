// make_appearance_pairs — writes labelled image-pair sets under strong appearance change for
// `visnav align --pairs` (error rate per detector) and `visnav train-descriptor` (issue 13).
//
//   make_appearance_pairs --out DIR [--set sim|photos|all] [--count N] [--seed S]
//                         [--world campus --route campus]
//
// Each set is a folder with PNG pairs and a `pairs.txt` of lines `A.png B.png SHIFT_PX`
// (SHIFT_PX: horizontal position of the scene in B minus its position in A, the `align`
// convention). Two sets the project can ship (generated, never downloaded):
//
//  * sim — the simulator's world along a route: A is the summer view (base textures), B the
//    same place in another season (winter snow or autumn textures), another time of day (gain
//    0.45-1.35, warm or cool colour cast, offset), shadows (world-fixed bands 0.3-0.7) and
//    sensor noise, from a pose 0-0.3 m to the side, 0-0.6 m along and 0-3° turned. Both are
//    rendered 1280×480 with a 90° field of view (f = 640 px) and cut to 1024×384 crops whose
//    windows differ by up to ±120 px; the label is the window shift plus f·tan(turn) (the shift at
//    the image centre; parallax from the side step makes near objects move more, as on a robot).
//  * photos — python3-skimage's real photographs, B = A's photo under a photometric change
//    (gamma 0.4-2.5, contrast, brightness, colour cast, an illumination gradient or shadow bands,
//    a "snow" wash that saturates bright areas, noise, blur, JPEG 20-90) and a geometric one
//    (scale 0.9-1.1 and rotation ±3° about the crop centre, vertical shift ±8 px), cut with a
//    horizontal shift of up to ±100 px (the label).
//
// Deterministic: the same seed gives the same files (std::mt19937_64 with explicit arithmetic on
// its raw output, not the standard distributions, which differ between library versions).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "visnav_sim/commands.hpp"
#include "visnav_sim/render.hpp"
#include "visnav_sim/route.hpp"
#include "visnav_sim/world.hpp"

namespace {

namespace fs = std::filesystem;

struct Rng {
  std::mt19937_64 g;
  explicit Rng(std::uint64_t seed) : g(seed) {}
  double uniform(double lo, double hi) { return lo + (hi - lo) * (static_cast<double>(g() >> 11) / 9007199254740992.0); }
  int integer(int lo, int hi) { return lo + static_cast<int>(g() % static_cast<std::uint64_t>(hi - lo + 1)); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
};

constexpr double kPi = 3.14159265358979323846;

bool write(const fs::path& p, const cv::Mat& img, int jpeg_quality = 0) {
  if (jpeg_quality > 0) {  // round trip through JPEG, stored as PNG
    std::vector<std::uint8_t> buf;
    cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
    return cv::imwrite(p.string(), cv::imdecode(buf, cv::IMREAD_UNCHANGED));
  }
  return cv::imwrite(p.string(), img);
}

// Illumination change of a BGR image: out = ((in/255)^gamma * contrast + brightness) * cast.
cv::Mat photometric(const cv::Mat& bgr, Rng& r) {
  cv::Mat f;
  bgr.convertTo(f, CV_32FC3, 1.0 / 255.0);
  const double gamma = std::exp(r.uniform(std::log(0.4), std::log(2.5)));
  cv::pow(f, gamma, f);
  const double contrast = r.uniform(0.5, 1.4), brightness = r.uniform(-0.15, 0.2);
  const cv::Scalar cast(r.uniform(0.8, 1.2), r.uniform(0.85, 1.15), r.uniform(0.8, 1.2));
  f = f * contrast + cv::Scalar::all(brightness);
  cv::multiply(f, cast, f);
  // Illumination gradient or shadow bands across the image.
  cv::Mat light(f.size(), CV_32FC1);
  const bool bands = r.chance(0.5);
  const double angle = r.uniform(0.0, kPi), period = r.uniform(60.0, 200.0), depth = r.uniform(0.3, 0.6);
  const double phase = r.uniform(0.0, 2 * kPi);
  for (int y = 0; y < light.rows; ++y)
    for (int x = 0; x < light.cols; ++x) {
      const double t = x * std::cos(angle) + y * std::sin(angle);
      const double v = bands ? (std::sin(2 * kPi * t / period + phase) > 0.3 ? 1.0 - depth : 1.0)
                             : 1.0 - depth * t / (light.cols + light.rows);
      light.at<float>(y, x) = static_cast<float>(v);
    }
  if (bands) cv::GaussianBlur(light, light, cv::Size(0, 0), 3.0);
  cv::Mat light3;
  cv::merge(std::vector<cv::Mat>{light, light, light}, light3);
  cv::multiply(f, light3, f);
  if (r.chance(0.35)) {  // snow wash: bright, low-saturation areas become white
    cv::Mat grey;
    cv::cvtColor(f, grey, cv::COLOR_BGR2GRAY);
    cv::Mat mask;
    cv::threshold(grey, mask, r.uniform(0.35, 0.6), 1.0, cv::THRESH_BINARY);
    cv::GaussianBlur(mask, mask, cv::Size(0, 0), 2.0);
    cv::Mat mask3;
    cv::merge(std::vector<cv::Mat>{mask, mask, mask}, mask3);
    cv::Mat white(f.size(), f.type(), cv::Scalar::all(0.95));
    f = f.mul(cv::Scalar::all(1.0) - mask3) + white.mul(mask3);
  }
  cv::Mat out;
  f.convertTo(out, CV_8UC3, 255.0);
  const double blur = r.uniform(0.0, 1.8);
  if (blur > 0.4) cv::GaussianBlur(out, out, cv::Size(0, 0), blur);
  cv::Mat noise(out.size(), CV_16SC3);
  cv::randn(noise, 0, r.uniform(0.0, 8.0));
  cv::Mat o16;
  out.convertTo(o16, CV_16SC3);
  o16 += noise;
  o16.convertTo(out, CV_8UC3);
  return out;
}

struct Args {
  fs::path out;
  std::string set = "all";
  int count = 100;
  std::uint64_t seed = 1;
  std::string world = "campus", route = "campus";
};

int make_photos(const Args& a, Rng& r) {
  const fs::path dir = a.out / "photos";
  fs::create_directories(dir);
  const std::string base = visnav::sim::skimage_data_dir();
  const char* names[] = {"astronaut.png", "camera.png", "chelsea.png", "coffee.png", "rocket.jpg",
                         "motorcycle_left.png", "motorcycle_right.png", "brick.png", "grass.png", "gravel.png",
                         "coins.png", "page.png", "moon.png", "text.png", "hubble_deep_field.jpg", "ihc.png", "retina.jpg", "color.png"};
  std::vector<cv::Mat> photos;
  for (const char* n : names) {
    cv::Mat img = cv::imread(base + "/" + n, cv::IMREAD_COLOR);
    if (img.empty() || img.cols < 300 || img.rows < 250) continue;
    // Width 840: a 640 px crop can move ±100 px.
    cv::resize(img, img, cv::Size(840, static_cast<int>(std::lround(img.rows * 840.0 / img.cols))), 0, 0, cv::INTER_AREA);
    photos.push_back(img);
  }
  if (photos.empty()) {
    std::fprintf(stderr, "make_appearance_pairs: no photos in %s (install python3-skimage)\n", base.c_str());
    return 1;
  }
  std::ofstream list(dir / "pairs.txt");
  list << "# A B SHIFT_PX: skimage photos, B = photometric + geometric change (make_appearance_pairs, seed "
       << a.seed << ")\n";
  for (int i = 0; i < a.count; ++i) {
    const cv::Mat& src = photos[static_cast<std::size_t>(i) % photos.size()];
    const int h = std::min(360, src.rows - 24);
    const int y0 = (src.rows - h) / 2;
    const int shift = r.integer(-100, 100);
    // B: warp about the centre of its crop window, then cut the window moved by -shift (the
    // scene then sits `shift` px further right in B).
    const double scale = r.uniform(0.9, 1.1), rot = r.uniform(-3.0, 3.0), dy = r.uniform(-8.0, 8.0);
    const int xb = 100 - shift;
    cv::Mat m = cv::getRotationMatrix2D(cv::Point2f(static_cast<float>(xb + 320), static_cast<float>(y0 + h / 2)), rot, scale);
    m.at<double>(1, 2) += dy;
    cv::Mat warped;
    cv::warpAffine(src, warped, m, src.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    const cv::Mat a_img = src(cv::Rect(100, y0, 640, h));
    const cv::Mat b_img = photometric(warped(cv::Rect(xb, y0, 640, h)), r);
    char na[64], nb[64];
    std::snprintf(na, sizeof na, "p%03d_a.png", i);
    std::snprintf(nb, sizeof nb, "p%03d_b.png", i);
    const int q = r.chance(0.5) ? r.integer(20, 90) : 0;
    if (!write(dir / na, a_img) || !write(dir / nb, b_img, q)) {
      std::fprintf(stderr, "make_appearance_pairs: cannot write into %s\n", dir.c_str());
      return 1;
    }
    list << na << ' ' << nb << ' ' << shift << '\n';
  }
  std::printf("photos: %d pairs in %s\n", a.count, dir.c_str());
  return 0;
}

int make_sim(const Args& a, Rng& r) {
  using namespace visnav::sim;
  const fs::path dir = a.out / "sim";
  fs::create_directories(dir);
  auto route_path = resolve_route_path(a.route);
  if (!route_path) { std::fprintf(stderr, "make_appearance_pairs: %s\n", route_path.error().message.c_str()); return 1; }
  auto route = load_route(*route_path);
  if (!route) { std::fprintf(stderr, "make_appearance_pairs: %s\n", route.error().message.c_str()); return 1; }
  auto world_path = resolve_world_path(a.world);
  if (!world_path) { std::fprintf(stderr, "make_appearance_pairs: %s\n", world_path.error().message.c_str()); return 1; }
  auto world = load_world(*world_path);
  if (!world) { std::fprintf(stderr, "make_appearance_pairs: %s\n", world.error().message.c_str()); return 1; }
  RobotParams rp;
  rp.world = *world_path;
  auto drive = drive_route(*route, rp, 10.0, 3600.0);
  if (!drive || drive->size() < 2) {
    std::fprintf(stderr, "make_appearance_pairs: cannot drive route '%s'\n", a.route.c_str());
    return 1;
  }
  CameraModel cam;
  cam.width_px = 1280;
  cam.height_px = 480;
  cam.hfov_deg = 90.0;
  const double f_px = cam.fx();
  Renderer summer(*world, cam);
  const char* seasons[] = {"winter", "autumn", "winter"};
  std::ofstream list(dir / "pairs.txt");
  list << "# A B SHIFT_PX: simulator " << a.world << " along route " << a.route
       << ", A summer, B other season / time of day / shadows from a displaced pose (make_appearance_pairs, seed "
       << a.seed << ")\n";
  cv::Mat ia, ib;
  for (int i = 0; i < a.count; ++i) {
    // A random place in the i-th stretch of the route: other seeds give other places.
    const double at = (i + r.uniform(0.0, 1.0)) * static_cast<double>(drive->size()) / a.count;
    const auto& s = (*drive)[std::min(drive->size() - 1, static_cast<std::size_t>(at))];
    const visnav::Pose2D pa = s.ground_truth;
    const double side_m = r.uniform(-0.3, 0.3), along_m = r.uniform(-0.6, 0.6), turn_rad = r.uniform(-3.0, 3.0) * kPi / 180.0;
    visnav::Pose2D pb = pa;
    pb.x_m += along_m * std::cos(pa.heading_rad) - side_m * std::sin(pa.heading_rad);
    pb.y_m += along_m * std::sin(pa.heading_rad) + side_m * std::cos(pa.heading_rad);
    pb.heading_rad += turn_rad;
    RenderOptions o;
    o.season = seasons[i % 3];
    o.shadows.strength = r.uniform(0.3, 0.7);
    o.shadows.direction_deg = r.uniform(0.0, 180.0);
    Renderer other(*world, cam, o);
    summer.render(pa, ia);
    other.render(pb, ib);
    // Time of day: gain, colour cast, offset, sensor noise.
    cv::Mat f;
    ib.convertTo(f, CV_32FC3);
    const double gain = r.uniform(0.45, 1.35);
    const bool warm = r.chance(0.5);
    cv::multiply(f, cv::Scalar(gain * (warm ? 0.85 : 1.1), gain, gain * (warm ? 1.12 : 0.9)), f);
    f += cv::Scalar::all(r.uniform(-10.0, 20.0));
    cv::Mat noise(f.size(), CV_32FC3);
    cv::randn(noise, 0, r.uniform(1.0, 5.0));
    f += noise;
    f.convertTo(ib, CV_8UC3);
    const int window = r.integer(-120, 120);
    const double shift_px = f_px * std::tan(turn_rad) - window;
    const cv::Mat ca = ia(cv::Rect(128, 48, 1024, 384));
    const cv::Mat cb = ib(cv::Rect(128 + window, 48, 1024, 384));
    char na[64], nb[64];
    std::snprintf(na, sizeof na, "s%03d_a.png", i);
    std::snprintf(nb, sizeof nb, "s%03d_b.png", i);
    if (!write(dir / na, ca) || !write(dir / nb, cb)) {
      std::fprintf(stderr, "make_appearance_pairs: cannot write into %s\n", dir.c_str());
      return 1;
    }
    char shift[32];
    std::snprintf(shift, sizeof shift, "%.1f", shift_px);
    list << na << ' ' << nb << ' ' << shift << '\n';
  }
  std::printf("sim: %d pairs in %s\n", a.count, dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : std::string(); };
    if (k == "--out") a.out = next();
    else if (k == "--set") a.set = next();
    else if (k == "--count") a.count = std::atoi(next().c_str());
    else if (k == "--seed") a.seed = std::strtoull(next().c_str(), nullptr, 10);
    else if (k == "--world") a.world = next();
    else if (k == "--route") a.route = next();
    else {
      std::fprintf(stderr,
                   "usage: make_appearance_pairs --out DIR [--set sim|photos|all] [--count N] [--seed S] "
                   "[--world W --route R]\n");
      return 2;
    }
  }
  if (a.out.empty() || a.count < 1 || (a.set != "sim" && a.set != "photos" && a.set != "all")) {
    std::fprintf(stderr, "make_appearance_pairs: need --out DIR, --count >= 1, --set sim|photos|all\n");
    return 2;
  }
  Rng r(a.seed);
  int rc = 0;
  if (a.set == "photos" || a.set == "all") rc |= make_photos(a, r);
  if (a.set == "sim" || a.set == "all") rc |= make_sim(a, r);
  return rc;
}
